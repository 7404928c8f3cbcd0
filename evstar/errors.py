"""The one exception family of evstar: every error a user can cause derives from EvstarError.

Each class also derives from the builtin a caller would catch without knowing evstar
(``except ValueError`` and ``except evstar.EvstarError`` both work), and carries the exit
code the command line ends with (``evstar.cli`` prints one line and exits with it).
"""


class EvstarError(Exception):
    """Base class of all evstar errors."""

    exit_code = 1


class ParameterError(EvstarError, ValueError):
    """A parameter (constructor argument, config key, command-line option) out of range."""

    exit_code = 2


class ParameterTypeError(EvstarError, TypeError):
    """An argument of the wrong type, e.g. a numpy array where evstar.Events is expected."""

    exit_code = 2


class DataError(EvstarError, ValueError):
    """Arrays that break the data model (dtype, range, order, finiteness), or inputs that do
    not belong together (a truth file or camera of another recording)."""

    exit_code = 3


class FormatError(EvstarError, ValueError):
    """A file that cannot be read or written: unknown extension, corrupt content, missing column."""

    exit_code = 3

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


class OutputError(EvstarError, OSError):
    """An output that cannot be written where asked: unwritable folder, a file in the way,
    or the path of an input (evstar never overwrites its inputs)."""

    exit_code = 4

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")

    def __str__(self):  # OSError's own __str__ would print the args tuple
        return self.args[0]


class BackendError(EvstarError, RuntimeError):
    """A requested compute backend or device is not available."""

    exit_code = 5


class EvstarWarning(UserWarning):
    """Suspicious but usable input, e.g. IMU data that do not cover the events."""
