"""The one exception type users see: an input problem reported on a single line."""

from __future__ import annotations


class InputError(Exception):
    """Bad input: names the file, the column or parameter, the row, and what was expected.

    ``channel`` names a source channel (MDF4 channel or the CSV column a map reads) where it
    differs from the contract ``column`` it feeds.

    The CLI prints ``str(error)`` as one line and exits non-zero; no traceback unless
    ``--debug``.
    """

    def __init__(
        self,
        file: str,
        expected: str,
        *,
        column: str | None = None,
        row: int | None = None,
        channel: str | None = None,
    ) -> None:
        self.file = str(file)
        self.channel = channel
        self.column = column
        self.row = row
        self.expected = expected
        super().__init__(self._line())

    def _line(self) -> str:
        parts = [self.file]
        if self.channel is not None:
            parts.append(f"channel '{self.channel}'")
        if self.column is not None:
            parts.append(f"column '{self.column}'")
        if self.row is not None:
            parts.append(f"row {self.row}")
        return ": ".join(parts) + f": {self.expected}"
