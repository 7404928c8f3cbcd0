"""The one exception family of evstar: every error a user can cause derives from EvstarError."""


class EvstarError(Exception):
    """Base class of all evstar errors."""


class DataError(EvstarError, ValueError):
    """Arrays that break the data model (dtype, range, order, finiteness)."""


class FormatError(EvstarError, ValueError):
    """A file that cannot be read or written: unknown extension, corrupt content, missing column."""

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


class BackendError(EvstarError, RuntimeError):
    """A requested compute backend or device is not available."""


class EvstarWarning(UserWarning):
    """Suspicious but usable input, e.g. IMU data that do not cover the events."""
