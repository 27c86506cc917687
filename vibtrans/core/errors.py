"""The library's error types.

Every refusal of bad input raises `InputError` (a ValueError) or, for a
value of the wrong kind, `InputTypeError` (an InputError and a TypeError),
with a message naming the parameter and its valid range.  Front ends
(`vibtrans.cli`, the explorer) catch these and nothing else, so a bug still
shows its traceback.
"""


class InputError(ValueError):
    """A value outside its valid range, refused before any work starts."""


class InputTypeError(InputError, TypeError):
    """A value of the wrong kind (text where a number belongs, ...)."""


class StepBudgetExceeded(InputError):
    """The scene would take more steps than allowed (refused before running)."""


class StoreMismatch(InputError):
    """A store on disk was made by a different command or is damaged."""


class Cancelled(RuntimeError):
    """A run was cancelled by its caller."""
