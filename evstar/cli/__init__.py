"""evstar: event-camera processing for star sensors (denoise, extract, track, compensate).

Every failure ends in one line on stderr, ``evstar CMD: error: ...``, and an exit code
that says what went wrong (no traceback unless --debug):

    2  bad option or parameter        3  unreadable or inconsistent input
    4  output cannot be written       5  compute backend or device missing
    1  other evstar error             6  out of memory
    70 internal error (a bug: please report it with --debug's traceback)
    130 interrupted          141 stdout closed early (e.g. `evstar info F | head -1`), silently
"""
from __future__ import annotations

import argparse
import sys
import warnings
from importlib import import_module

from ..errors import EvstarError

# sub-command -> its one-line help; the module evstar.cli.<name> defines add_arguments(parser)
# and run(args), and its docstring is the command's description
COMMANDS = {
    "info": "summarise a recording (events, rate, sensor, IMU)",
    "convert": "convert a recording to another format (by extension)",
    "simulate": "simulate stars seen by an event camera on a turntable",
    "denoise": "denoise events: classical, NDSEF or MR-NDSEF filter",
    "extract": "extract star positions and tracks",
    "run": "run the whole pipeline and write results and figures",
    "calibrate": "measure the pixels' lag by brightness from a recording with IMU",
    "attitude": "inertial attitude from identified star tracks (camera -> ICRS)",
    "batch": "run the whole pipeline on many recordings at once (Dask)",
    "demo": "simulate the default scene and run the whole pipeline",
    "bench": "measure throughput per stage and backend",
}
EXIT_MEMORY, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_PIPE = 6, 70, 130, 141


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error (the usage is one --help away)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(argv=None):
    """The parser; only the sub-command named in `argv` gets its options (and imports its
    module), so `evstar --help` and every other command start without the rest."""
    # no abbreviations: `--forc` had been taken for --force
    parser = Parser(prog="evstar", description=__doc__, allow_abbrev=False,
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version="evstar 0.1.0")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    chosen = next((a for a in (sys.argv[1:] if argv is None else argv) if a in COMMANDS), None)
    for name, help_text in COMMANDS.items():
        if name != chosen:
            sub.add_parser(name, help=help_text)
            continue
        module = import_module(f".{name}", __name__)
        p = sub.add_parser(name, help=help_text, description=module.__doc__, allow_abbrev=False,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(p)
        # after the command too (where an error message suggests adding it)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show the traceback of an error")
        p.set_defaults(_run=module.run)
        parser.chosen = p     # its errors name the command
    return parser


def main(argv=None):
    try:
        parser = build_parser(argv)
        args, extra = parser.parse_known_args(argv)
        if extra:   # argparse leaves them to the top level, whose message names no command
            getattr(parser, "chosen", parser).error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code
    with warnings.catch_warnings():
        if not args.debug:   # one line per warning, like the errors (no source line)
            warnings.showwarning = _one_line_warning(args.command)
            # a dependency's deprecations are its maintainers' to act on, not a user's
            # (Taichi's first init calls locale.getdefaultlocale)
            warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"taichi\b")
        return _run(args)


def _one_line_warning(command):
    def show(message, category, filename, lineno, file=None, line=None):
        from .common import cli_wording

        print(f"evstar {command}: warning: {cli_wording(message)}",
              file=sys.stderr if file is None else file)
    return show


def _run(args):
    try:
        code = args._run(args) or 0
        sys.stdout.flush()    # a closed pipe shows here, not at interpreter exit
        return code
    except BrokenPipeError:   # the reader of stdout went away (head, less quit): nothing to say
        _stdout_to_devnull()
        return EXIT_PIPE
    except EvstarError as exc:
        return _fail(args, _named(args, exc), exc.exit_code, exc)
    except KeyboardInterrupt:
        print(f"evstar {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except MemoryError as exc:
        return _fail(args, f"out of memory ({exc or 'allocation failed'}); try smaller inputs "
                           "or parameters", EXIT_MEMORY, exc)
    except OSError as exc:  # e.g. a disk that fills up while writing
        return _fail(args, f"{exc.filename or ''}{': ' if exc.filename else ''}{exc.strerror or exc}",
                     4, exc)
    except Exception as exc:
        return _fail(args, f"internal error: {type(exc).__name__}: {exc} (rerun with --debug "
                           "for the traceback)", EXIT_INTERNAL, exc)


#: a data error that names the IMU or the truth but not its file: (the message's start,
#: the option whose file it is, else the input's)
_UNNAMED = (("the IMU ", "imu"), ("the truth ", "truth"))


def _named(args, exc):
    """The error's message, led by the file it is about where it names none (the library
    checks arrays, which know no path: an IMU file of another time span, a truth file of
    another recording)."""
    from ..errors import DataError

    message = str(exc)
    if isinstance(exc, DataError):
        for start, option in _UNNAMED:
            path = getattr(args, option, None) or getattr(args, "input", None)
            if message.startswith(start) and path and str(path) not in message:
                return f"{path}: {message}"
    return message


def _stdout_to_devnull():
    """Point stdout at /dev/null, so that the interpreter's final flush of what is still
    buffered for a closed pipe raises nothing (Python's documented remedy)."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):   # no real stdout descriptor (captured)
        pass


def _fail(args, message, code, exc=None):
    if args.debug:
        raise exc if exc is not None else message
    from .common import cli_wording

    print(f"evstar {args.command}: error: {cli_wording(message)}", file=sys.stderr)
    return code
