"""The `evstar` command: one module per sub-command, each with add_parser() and run().

Every failure ends in one line on stderr, ``evstar CMD: error: ...``, and an exit code
that says what went wrong (no traceback unless --debug):

    2  bad option or parameter        3  unreadable or inconsistent input
    4  output cannot be written       5  compute backend or device missing
    1  other evstar error             6  out of memory
    70 internal error (a bug: please report it with --debug's traceback)
    130 interrupted
"""
from __future__ import annotations

import argparse
import sys
from importlib import import_module

from ..errors import EvstarError

# sub-command name -> module in this package defining add_parser(subparsers) and run(args)
COMMANDS = ["info", "convert", "simulate", "denoise", "extract", "run", "demo", "bench"]
EXIT_MEMORY, EXIT_INTERNAL, EXIT_INTERRUPTED = 6, 70, 130


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error (the usage is one --help away)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser():
    parser = Parser(prog="evstar", description=__doc__,
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version="evstar 0.1.0")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        module = import_module(f".{name.replace('-', '_')}", __name__)
        p = module.add_parser(sub)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code
    try:
        return args._run(args) or 0
    except EvstarError as exc:
        return _fail(args, exc, exc.exit_code)
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


def _fail(args, message, code, exc=None):
    if args.debug:
        raise exc if exc is not None else message
    print(f"evstar {args.command}: error: {message}", file=sys.stderr)
    return code
