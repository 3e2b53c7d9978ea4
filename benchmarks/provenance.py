"""What every result file records about the code that produced it."""

from __future__ import annotations

import subprocess
from pathlib import Path

#: The repository the benchmarks belong to (whatever the working directory).
ROOT = Path(__file__).resolve().parent.parent


def commit() -> str:
    """``git rev-parse HEAD`` of the benchmarks' repository, with ``+dirty`` when tracked files
    differ from it (untracked files, e.g. results being written, do not count); '' outside a
    repository or without git."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True
        ).stdout
    except OSError:
        return ""
    return head.strip() + ("+dirty" if head.strip() and dirty.strip() else "")
