"""The ``jadhesion`` command line.

Each subcommand lives in its own module with ``register(subparsers)``, which adds the parser and sets
``func(args) -> int``. Every command takes ``--json``. Bad input raises :class:`UserError` (or a
:class:`ValueError` subclass from the data layer): one line on stderr, exit code 2, nothing written.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .common import UserError

COMMANDS = ("simulate", "fit", "reproduce", "posterior", "diagnose", "sweep", "online")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="jadhesion", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"jadhesion.cli.{name}")
        except ModuleNotFoundError as exc:  # a command whose module is not written yet
            if exc.name != f"jadhesion.cli.{name}":
                raise
            continue
        module.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from ..config import enable_compilation_cache, enable_x64

    enable_x64()
    enable_compilation_cache()
    try:
        return int(args.func(args) or 0)
    except (UserError, OSError) as exc:
        sys.stderr.write(f"jadhesion: error: {exc}\n")
        return 2
