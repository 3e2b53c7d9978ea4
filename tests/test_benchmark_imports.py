"""Every name a benchmark imports from this repository exists where it imports it from.

The benchmarks are run by hand, not by the suite, and most need the ``bench`` extra, so a helper
renamed in one place could break them silently (three imported a removed ``_commit`` for a day).
This reads the sources (``ast``, nothing is executed): for each ``from M import a, b`` in
``benchmarks/`` with ``M`` in ``benchmarks``, ``jadhesion`` or ``validation``, every name is a
top-level definition, assignment or import of ``M``, or a submodule of the package ``M``.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
OURS = ("benchmarks", "jadhesion", "validation")


def _module_path(dotted: str) -> Path | None:
    base = ROOT.joinpath(*dotted.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _top_level_names(path: Path) -> set:
    names, todo = set(), list(ast.parse(path.read_text()).body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            todo.extend(node.body + getattr(node, "orelse", []) + getattr(node, "finalbody", []))
            todo.extend(s for h in getattr(node, "handlers", []) for s in h.body)
    return names


def _imports(path: Path):
    package = "benchmarks"
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(parts + ([node.module] if node.module else []))
            else:
                module = node.module
            if module.split(".")[0] in OURS:
                yield node.lineno, module, [a.name for a in node.names]


@pytest.mark.parametrize("path", sorted((ROOT / "benchmarks").glob("*.py")), ids=lambda p: p.name)
def test_benchmark_imports_resolve(path):
    for line, module, names in _imports(path):
        target = _module_path(module)
        assert target is not None, f"{path.name}:{line}: no module {module}"
        defined = _top_level_names(target)
        for name in names:
            submodule = target.name == "__init__.py" and _module_path(f"{module}.{name}") is not None
            assert name in defined or submodule, f"{path.name}:{line}: {module} has no {name}"
