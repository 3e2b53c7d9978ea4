"""The ``jadhesion`` command line.

:data:`COMMANDS` names every subcommand, its module and its one-line help. A command's module
``jadhesion.cli.<name>`` holds only its argument definitions, ``register(subparsers)``, and imports
nothing heavier than argparse and :mod:`.common` (no JAX), so ``jadhesion --help`` imports no
command module and ``jadhesion <name> --help`` imports just that one. ``register`` names the code
that does the work with ``set_defaults(handler="module:function")``; :func:`main` imports that
module (heavy imports at its top) only after parsing, and calls ``function(args) -> int``. (A
``set_defaults(func=callable)`` is called as is.) A module that fails to import is an error, never
a missing command.

Every command takes ``--json``. Bad input raises :class:`UserError` (or a :class:`ValueError`
subclass from the data layer): one line on stderr, exit code 2, nothing written. A reader that
closes the pipe early (``jadhesion inspect run.csv --json | head -1``) ends the command quietly
with exit code 1, Python's convention for EPIPE; Ctrl-C ends it with one line and exit code 130
(a sweep resumes from its finished chunks when run again). A compilation cache that cannot be
made (``JADHESION_CACHE``, or ``~/.cache``, a file or not writable) is one warning line, and the
command runs without it.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys

from ..config import enable_compilation_cache, enable_x64
from .common import UserError

#: Subcommand → one-line help (the module is ``jadhesion.cli.<subcommand>``).
COMMANDS = {
    "simulate": "simulate a 22E traction-test recording",
    "fit": "identify Polach's parameters [kA, kS, mu0, A, B]",
    "reproduce": "reproduce the papers' tables (default: both)",
    "posterior": "Bayesian posterior of the Polach parameters (emcee)",
    "diagnose": "name the missing physics behind a Polach misfit",
    "sweep": "vectorised parameter sweep (scenarios × seeds × methods × …)",
    "inspect": "what a recording holds: rate, gaps, ranges, segments, what it can identify",
    "online": "track Kiencke's optimum sample by sample (paper 000) on a recording",
}


class _Parser(argparse.ArgumentParser):
    """argparse's parser whose errors are one line, as every other bad input's (argparse prints
    the usage first): ``jadhesion: error: COMMAND: MESSAGE (see jadhesion COMMAND --help)``, exit
    code 2."""

    def error(self, message):
        command = self.prog.removeprefix("jadhesion").strip()
        sys.stderr.write(
            f"jadhesion: error: {command + ': ' if command else ''}{message} (see {self.prog} --help)\n"
        )
        sys.exit(2)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser; with ``command``, only that subcommand's arguments are defined (its module
    imported), else every subcommand is listed with its one-line help and no module is imported."""
    parser = _Parser(
        prog="jadhesion", description="identify wheel–rail adhesion models from traction recordings"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for name, help_ in COMMANDS.items():
        if name == command:
            importlib.import_module(f"jadhesion.cli.{name}").register(sub)
        else:
            sub.add_parser(name, help=help_)
    return parser


def _handler(args):
    """The function that runs the parsed command: ``args.handler`` (``"module:function"``,
    imported now) or ``args.func``."""
    target = getattr(args, "handler", None)
    if target is None:
        return args.func
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)


def _negative_number(token: str) -> bool:
    """Whether ``token`` is a negative number argparse reads as an option: exponent or
    non-finite forms (``-1e3``, ``-inf``); ``-1`` and ``-1.5`` it reads as numbers itself."""
    if not token.startswith("-") or token.startswith("--"):
        return False
    try:
        float(token)
    except ValueError:
        return False
    return not re.fullmatch(r"-\d+|-\d*\.\d+", token)


def attach_negative_numbers(argv: list) -> list:
    """``--flag -1e3`` as ``--flag=-1e3``: argparse takes a value in exponent form for an option
    and answers "expected one argument" (``--start -1e3``); a flag without a value then says
    "ignored explicit argument", naming it."""
    out = []
    for token in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _negative_number(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def main(argv=None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), run the command; returns the exit code."""
    argv = attach_negative_numbers(sys.argv[1:] if argv is None else list(argv))
    command = argv[0] if argv and argv[0] in COMMANDS else None
    args = build_parser(command).parse_args(argv)
    enable_x64()
    try:
        enable_compilation_cache()
    except OSError as exc:  # a cache that cannot be made never stops a command; it is said
        sys.stderr.write(
            f"jadhesion: warning: no compilation cache ({exc}); every program is compiled anew: "
            "set JADHESION_CACHE to a writable directory\n"
        )
    try:
        return int(_handler(args)(args) or 0)
    except BrokenPipeError:
        return _closed_pipe()
    except KeyboardInterrupt:
        resume = " (run it again to resume from its finished chunks)" if command == "sweep" else ""
        sys.stderr.write(f"jadhesion: {command or 'command'} interrupted{resume}\n")
        return 130
    except (UserError, OSError) as exc:
        sys.stderr.write(f"jadhesion: error: {exc}\n")
        return 2


def _closed_pipe() -> int:
    """Point stdout at ``os.devnull`` (the interpreter's last flush would fail again) and return
    exit code 1."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 1


def leave(code: int):
    """Flush stdout and stderr, then end the process at once with ``code`` (``os._exit``).

    Every output file is written and closed by then (commands write synchronously, most through
    :mod:`jadhesion.atomic`, and start no thread or process; the compilation cache and the kept
    programs are written when they are made), so the interpreter's shutdown has nothing to save:
    it only tears down JAX's backend and the modules, 0.18–0.26 s of a warm ``fit`` process (A/B
    and ``benchmarks/bench_startup.py``), a third of a bare ``import jax``. Only the console entry
    points call this, never :func:`main` (tests call :func:`main` in their own process)."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        code = _closed_pipe()
    sys.stderr.flush()
    os._exit(code)


def console() -> None:
    """The ``jadhesion`` program (console script and ``python -m jadhesion``): :func:`main`, then
    :func:`leave`. An exception (``--help``'s ``SystemExit`` included) takes the ordinary exit."""
    leave(main())
