"""Process-wide JAX settings applied at the entry points (CLI, benchmarks, tests).

Library functions never call these themselves: they compute in the dtype of their inputs.
"""

from __future__ import annotations

import os
from pathlib import Path


def enable_x64() -> None:
    """Compute in float64 (results of this project are reported in double precision)."""
    import jax  # here, not at the top: the JAX-free CLI imports this module (``--help``: no JAX)

    jax.config.update("jax_enable_x64", True)


def compilation_cache_dir() -> Path:
    """The persistent compilation cache: ``$JADHESION_CACHE`` or, where it is unset or empty (not the
    current directory), ``~/.cache/jadhesion/xla``."""
    return Path(os.environ.get("JADHESION_CACHE") or Path.home() / ".cache" / "jadhesion" / "xla")


def program_cache_dir() -> Path:
    """Exported programs (:mod:`jadhesion.programs`), kept beside the compiled executables:
    ``<compilation cache>/exported``."""
    return compilation_cache_dir() / "exported"


def enable_compilation_cache(path: str | os.PathLike | None = None) -> Path:
    """Persist compiled XLA programs so a second CLI run does not pay compilation again.

    The cache lives in ``$JADHESION_CACHE`` or ``~/.cache/jadhesion/xla`` unless ``path`` is given.
    """
    import jax  # here, not at the top: see enable_x64

    cache = Path(path) if path else compilation_cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(cache))
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.1)
    return cache
