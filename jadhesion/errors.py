"""Exceptions raised at the library's boundary."""


class InputError(ValueError):
    """Bad user input (a file, a column, a row, an argument). Its message is one self-contained line
    naming what is wrong and where; the CLI prints it and exits with code 2."""


class RecordingError(InputError):
    """A recording (CSV or sidecar) that cannot be used: message names file, column and row."""


class VehicleError(InputError):
    """A vehicle whose numbers (a sidecar's) give no usable contact; the message names the vehicle
    and the keys to check, a caller that knows the sidecar adds its path."""
