"""Errors raised by the physics core.

Every error names the offending field and its value, so that a command line or an FMU can
pass the message on unchanged.
"""


class CycloidInputError(ValueError):
    """Bad input to the cycloid-drive model (a design value, an operating point, a mode)."""

    def __init__(self, field: str, value, reason: str):
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"{field} = {value!r}: {reason}")
