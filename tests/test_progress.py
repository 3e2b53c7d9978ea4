"""The CLI's progress bar (``jadhesion.cli.common.Progress``): the library's ``progress(done, total)``
callback, drawn by tqdm at a terminal and silent in a log or a pipe."""

import io

from jadhesion.cli.common import Progress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_silent_when_stderr_is_not_a_terminal(capsys):
    with Progress(label="sweep", unit="fits") as progress:
        progress(3, 5)
        progress(5, 5)
    assert progress.done == 5
    assert capsys.readouterr() == ("", "")


def test_draws_counts_and_total_at_a_terminal(monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    with Progress(label="sweep", unit="fits") as progress:
        progress(3, 5)
        progress.update(2)
    assert progress.done == 5
    text = terminal.getvalue()
    assert "sweep" in text and "5/5" in text


def test_disabled_on_request_even_at_a_terminal(monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    with Progress(4, "posterior", "steps", enabled=False) as progress:
        progress.update(4)
    assert progress.done == 4 and terminal.getvalue() == ""
