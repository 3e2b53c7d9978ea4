"""What a sweep's numbers depend on besides the grid: the code that computes them and where it runs.

Part files are keyed on :func:`code_hash` as well as the grid, so an interrupted sweep resumed after
a code change recomputes its parts instead of merging stale ones. The hash covers

* the source of the packages on the computing path (:data:`PACKAGES`: models, data, identify,
  sweeps, and the status enumeration) and of a custom dataset source's module;
* the JAX and jaxlib versions, whether float64 is on, and the platform and device kind (a part
  computed on a GPU is not the bits a CPU gives).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
from pathlib import Path

import jax
import jaxlib

_ROOT = Path(__file__).resolve().parents[1]
#: Source files and folders of jadhesion, relative to the package, that compute a sweep's numbers.
PACKAGES = ("models", "data", "identify", "sweeps", "status.py")


def source_digest(paths, root: Path) -> str:
    """SHA-256 of the ``.py`` files under ``paths`` (files or folders, relative to ``root``), each
    named by its path relative to ``root``, in sorted order."""
    digest = hashlib.sha256()
    files = []
    for rel in paths:
        path = root / rel
        files += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    for file in sorted(files):
        digest.update(file.relative_to(root).as_posix().encode() + b"\0")
        digest.update(file.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=None)
def _package_digest() -> str:
    return source_digest(PACKAGES, _ROOT)


def _simulate_source(simulate) -> str:
    if simulate is None:
        return ""
    file = Path(inspect.getsourcefile(simulate)).resolve()
    return source_digest([file.name], file.parent)


def code_hash(simulate=None, devices=None) -> str:
    """A digest of the code and runtime that compute a sweep's parts (see the module docstring).

    ``simulate``: a custom dataset source (its module's file is hashed too); ``devices``: the
    devices the sweep runs on (default ``jax.local_devices()``).
    """
    devices = jax.local_devices() if devices is None else devices
    runtime = {
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "x64": bool(jax.config.jax_enable_x64),
        "devices": sorted({(d.platform, d.device_kind) for d in devices}),
    }
    blob = json.dumps(
        {"package": _package_digest(), "simulate": _simulate_source(simulate), "runtime": runtime},
        sort_keys=True,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]
