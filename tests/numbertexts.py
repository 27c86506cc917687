"""Texts that look like numbers to a reader but are no plain number in the
explorer's fields and links (urlstate.PLAIN_NUMBER): digit separators,
hexadecimal, a decimal comma, vulgar fractions, other scripts' digits,
full-width digits, a superscript."""

LOOKALIKE_NUMBERS = ["1_0", "0x10", "1,5", "½", "١", "１", "²"]
