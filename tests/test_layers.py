"""The package's one-way layers (``[tool.importlinter]`` in pyproject.toml) hold: no module imports
from a layer above its own, and nothing imports ``jadhesion.cli``."""

from pathlib import Path

import pytest

importlinter_cli = pytest.importorskip("importlinter.cli", reason="import-linter not installed")

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def test_layers_contract_is_kept(capsys):
    code = importlinter_cli.lint_imports(config_filename=str(PYPROJECT), no_cache=True, no_logo=True)
    assert code == 0, capsys.readouterr().out[-4000:]


def test_the_contract_catches_an_upward_import(tmp_path, capsys):
    """The same contract with ``models`` placed above ``cli`` must fail: the check has power."""
    text = PYPROJECT.read_text(encoding="utf-8")
    assert '    "cli",\n' in text
    flipped = text.replace('    "cli",\n', '    "models",\n    "cli",\n', 1).replace(
        '    "models",\n    "report', '    "report', 1
    )
    config = tmp_path / "pyproject.toml"
    config.write_text(flipped, encoding="utf-8")
    code = importlinter_cli.lint_imports(config_filename=str(config), no_cache=True, no_logo=True)
    assert code == 1
    assert "jadhesion.cli is not allowed to import jadhesion.models" in capsys.readouterr().out
