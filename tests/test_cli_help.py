"""The command line's ``--help`` starts no JAX, and a command module that fails to import is an error.

Each check runs in a fresh interpreter (``sys.modules`` of this one already holds JAX).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from jadhesion.cli import COMMANDS, attach_negative_numbers, main, sweep

REPO = Path(__file__).resolve().parents[1]

_PROBE = """
import runpy, sys
sys.argv = ["jadhesion", *sys.argv[1:], "--help"]
try:
    runpy.run_module("jadhesion", run_name="__main__")
except SystemExit as exc:
    code = exc.code
sys.stdout.flush()
sys.stderr.write(f"exit={code} jax={'jax' in sys.modules}\\n")
"""


def _help(*argv, preload=""):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(
        [sys.executable, "-c", preload + _PROBE, *argv],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return proc.stdout, proc.stderr.strip().splitlines()[-1]


def test_top_level_help_lists_every_command_without_jax():
    out, status = _help()
    assert status == "exit=0 jax=False"
    words = " ".join(out.split())  # argparse wraps the help lines
    for name, line in COMMANDS.items():
        assert f"{name} {line}" in words


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_command_help_imports_no_jax(command):
    out, status = _help(command)
    assert status == "exit=0 jax=False"
    assert out.startswith(f"usage: jadhesion {command}")


def test_the_probe_sees_jax_when_it_is_imported():
    out, status = _help("simulate", preload="import jax\n")
    assert status == "exit=0 jax=True" and out.startswith("usage: jadhesion simulate")


def test_a_command_module_that_fails_to_import_is_an_error(monkeypatch):
    monkeypatch.setitem(COMMANDS, "missing", "a command whose module does not exist")
    with pytest.raises(ModuleNotFoundError, match="jadhesion.cli.missing"):
        main(["missing", "--help"])


def test_a_handler_that_fails_to_import_is_an_error(monkeypatch):
    def register(sub):
        sub.add_parser("sweep").set_defaults(handler="jadhesion.cli.no_such_module:run")

    monkeypatch.setattr(sweep, "register", register)
    with pytest.raises(ModuleNotFoundError, match="jadhesion.cli.no_such_module"):
        main(["sweep"])


def test_negative_numbers_in_exponent_form_are_option_values():
    """argparse reads ``--start -1e3`` as two options ("expected one argument"); the command line
    passes it as ``--start=-1e3``. ``-1``, ``-1.5``, names and ``--flag=value`` stay as they are."""
    assert attach_negative_numbers(["fit", "a.csv", "--start", "-1e3", "--end", "-inf"]) == [
        "fit",
        "a.csv",
        "--start=-1e3",
        "--end=-inf",
    ]
    kept = ["fit", "--start", "-1.5", "--end", "-2", "--start=-1e3", "-h", "--column", "-x=y"]
    assert attach_negative_numbers(kept) == kept


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["fit", "run.csv", "--bogus"],
            "jadhesion: error: unrecognized arguments: --bogus (see jadhesion --help)",
        ),
        (["fitt"], "jadhesion: error: argument command: invalid choice: 'fitt'"),
        (
            ["fit", "--method", "zz", "run.csv"],
            "jadhesion: error: fit: argument --method: invalid choice: 'zz'",
        ),
        (["posterior"], "jadhesion: error: posterior: the following arguments are required: file"),
    ],
)
def test_a_bad_flag_is_one_line_and_exit_2(capsys, argv, line):
    """argparse's own errors (unknown flag, bad choice, missing argument) are one line naming the
    command and its --help, exit code 2, as every other bad input; argparse printed its usage first."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and err.startswith(line)
