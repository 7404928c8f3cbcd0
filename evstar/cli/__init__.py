"""The `evstar` command: one module per sub-command, each with add_parser() and run()."""
from __future__ import annotations

import argparse
import sys
from importlib import import_module

from ..errors import EvstarError

# sub-command name -> module in this package defining add_parser(subparsers) and run(args)
COMMANDS = ["info", "convert", "simulate", "denoise", "extract", "run", "demo", "bench"]


def build_parser():
    parser = argparse.ArgumentParser(prog="evstar", description=__doc__)
    parser.add_argument("--version", action="version", version="evstar 0.1.0")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        module = import_module(f".{name.replace('-', '_')}", __name__)
        p = module.add_parser(sub)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args._run(args) or 0
    except EvstarError as exc:
        print(f"evstar {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"evstar {args.command}: interrupted", file=sys.stderr)
        return 130
