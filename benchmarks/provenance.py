"""What every result file records about the code that produced it."""

from __future__ import annotations

import subprocess


def commit() -> str:
    """``git rev-parse HEAD`` of the working directory's repository ('' outside one)."""
    return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
