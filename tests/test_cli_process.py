"""How a command ends when its reader or its user stops it (a closed pipe, Ctrl-C), and when its
compilation cache cannot be made."""

import json
import os
import subprocess
import sys

import pytest

import jadhesion.cli as cli
from jadhesion.data.recording import save_recording


@pytest.fixture(scope="module")
def creepage_csv(tmp_path_factory):
    """A small fitting dataset (creep, speed, adhesion) any command reads."""
    creep = [0.001 * (i + 1) for i in range(60)]
    path = tmp_path_factory.mktemp("end") / "creep.csv"
    save_recording(
        {"creepage": creep, "vehicle_speed": [2.0] * 60, "adhesion": [0.3 * c / (c + 0.01) for c in creep]},
        path=path,
    )
    return path


def test_a_closed_pipe_ends_the_command_quietly(creepage_csv):
    """A reader that closed the pipe before the output (``… --json | head -1``): exit code 1,
    nothing on stderr (no traceback, no "Broken pipe" error line)."""
    read, write = os.pipe()
    os.close(read)
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "jadhesion", "inspect", str(creepage_csv), "--json"],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=300,
        )
    finally:
        os.close(write)
    assert proc.returncode == 1 and proc.stderr == ""


@pytest.mark.parametrize("command, hint", [("fit", False), ("sweep", True)])
def test_ctrl_c_is_one_line_and_exit_130(capsys, monkeypatch, creepage_csv, command, hint):
    """Ctrl-C (KeyboardInterrupt in the command's work) is one line naming the command, exit
    code 130, no traceback; a sweep's line says a rerun resumes."""

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_handler", lambda args: interrupted)
    argv = ["fit", str(creepage_csv)] if command == "fit" else ["sweep", "--out", "s.csv"]
    assert cli.main(argv) == 130
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [err.strip()] and f"{command} interrupted" in err
    assert ("resume" in err) is hint


def _inspect(creepage_csv, cwd, **env):
    return subprocess.run(
        [sys.executable, "-m", "jadhesion", "inspect", str(creepage_csv), "--json"],
        env={**os.environ, **env},
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.parametrize("where", ["file", "under_file"])
def test_a_cache_that_cannot_be_made_is_one_warning_not_a_traceback(tmp_path, creepage_csv, where):
    """``JADHESION_CACHE`` naming a file (or a folder under one): the command runs without the
    cache and says so in one line (was a FileExistsError/NotADirectoryError traceback, exit 1,
    in every command)."""
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    cache = blocker if where == "file" else blocker / "xla"
    proc = _inspect(creepage_csv, tmp_path, JADHESION_CACHE=str(cache))
    assert proc.returncode == 0 and json.loads(proc.stdout)["samples"] == 60
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "warning" in lines[0] and "JADHESION_CACHE" in lines[0], proc.stderr


def test_an_empty_cache_variable_is_the_default_not_the_current_directory(tmp_path, creepage_csv):
    """``JADHESION_CACHE=`` (set, empty) means the default ``~/.cache/jadhesion/xla``; it was
    ``Path("")``, the current directory, which filled with compiled programs."""
    work, home = tmp_path / "work", tmp_path / "home"
    work.mkdir()
    proc = _inspect(creepage_csv, work, JADHESION_CACHE="", HOME=str(home))
    assert proc.returncode == 0, proc.stderr
    assert list(work.iterdir()) == []
    assert (home / ".cache" / "jadhesion" / "xla").is_dir()
