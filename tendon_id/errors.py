"""Errors for user mistakes: each names the file, the column and the row where it can."""

from __future__ import annotations


class TendonIdError(Exception):
    """Base class of errors caused by user input (the CLI exits with code 2)."""


class RecordingError(TendonIdError, ValueError):
    """A recording failed validation.

    Parameters
    ----------
    reason : str
        What is wrong, in one line.
    file : str, optional
        The file it came from.
    column : str, optional
        The offending column.
    row : int, optional
        The 0-based data row (frame index) of the first offending value.
    """

    def __init__(self, reason: str, *, file: str | None = None, column: str | None = None, row: int | None = None):
        self.reason = reason
        self.file = file
        self.column = column
        self.row = row
        super().__init__(self._message())

    def _message(self) -> str:
        where = []
        if self.file:
            where.append(str(self.file))
        if self.column is not None:
            where.append(f"column '{self.column}'")
        if self.row is not None:
            where.append(f"row {self.row}")
        return ": ".join([", ".join(where), self.reason]) if where else self.reason


class ConfigError(TendonIdError, ValueError):
    """A recipe, option or configuration value is invalid."""
