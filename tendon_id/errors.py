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
    """A recipe, option or configuration value is invalid.

    Parameters
    ----------
    reason : str
        What is wrong, in one line.
    param : str, optional
        The library parameter (or recipe key) whose value is wrong. The message starts with it
        (``"frames: must be at least 2, got 1"``); the command line names its flag instead
        (:meth:`message_for`).
    """

    def __init__(self, reason: str, *, param: str | None = None):
        self.reason = reason
        self.param = param
        super().__init__(f"{param}: {reason}" if param else reason)

    def message_for(self, flags: dict[str, str]) -> str:
        """The message with the parameter replaced by its command-line flag where ``flags`` has one.

        Parameters
        ----------
        flags : dict
            Parameter name -> flag (``{"frames": "--frames"}``), those of the command that ran.
        """
        if self.param and self.param in flags:
            return f"{flags[self.param]}: {self.reason}"
        return str(self)


class OutputError(TendonIdError, OSError):
    """A file could not be written (a full disk, no permission): the message names it; no old file was replaced."""


class NonFiniteResult(TendonIdError, ArithmeticError):
    """A fit, calibration or metric came out NaN or infinite: never a result (the CLI exits with code 2).

    The message names the value and the input it was computed from.
    """


class DefaultedGeometryWarning(UserWarning):
    """The data did not describe part of the robot, and the paper robot's value stood in for it.

    Raised by :func:`tendon_id.zoo.inputs.robot_of`, naming every defaulted field and its value;
    the command line prints it as one ``tendon-id: warning:`` line.
    """
