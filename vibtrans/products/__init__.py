"""What users take away: figures defined once for two backends (`plots`),
exports, and the design charts for a device in SI units."""
