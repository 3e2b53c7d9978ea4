"""Strict test settings: float64, no silent rank promotion, fixed keys (see STYLE.md §7)."""

import os
from pathlib import Path

import jax
import pytest

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("JADHESION_SHARED", REPO.parent / "shared"))


@pytest.fixture
def shared_dir() -> Path:
    if not SHARED.exists():
        pytest.fail(f"reference data not found at {SHARED} (set JADHESION_SHARED)")
    return SHARED
