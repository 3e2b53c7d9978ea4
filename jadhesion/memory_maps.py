"""Memory maps held by compiled programs, and their release before Linux's per-process limit.

Every program XLA:CPU compiles keeps memory maps (about three per JIT kernel: code, read-only data,
data) for as long as JAX's caches hold it: about 1 040 for a Polach LM fit, 300 for its trust block
and 310 for the observer and smoother, each once per length bucket
(:mod:`jadhesion.data.length_buckets`). Past ``vm.max_map_count`` (65 530 by default) LLVM's section
allocator aborts the process ("Unable to allocate section memory"): ``jadhesion fit DIR`` over 24
recordings of distinct lengths added 15 235 maps while the trust block, observer and smoother were
compiled per length (about 635 a file, so about 100 such files aborted it), and 3 092 now. Buckets
bound the count only per bucket, so a loop over recordings still calls :func:`release_if_near_limit`
between them; the command line does after each file's load (``fit``'s files).
"""

from __future__ import annotations

import gc

import jax

MAPS = "/proc/self/maps"
LIMIT = "/proc/sys/vm/max_map_count"


def map_count() -> int | None:
    """Memory maps this process holds (None where ``/proc`` does not say: not Linux)."""
    try:
        with open(MAPS) as maps:
            return sum(1 for _ in maps)
    except OSError:
        return None


def map_limit() -> int | None:
    """The kernel's per-process limit on memory maps (None where ``/proc`` does not say)."""
    try:
        with open(LIMIT) as limit:
            return int(limit.read())
    except (OSError, ValueError):
        return None


def release_if_near_limit(share: float = 0.5) -> bool:
    """Clear JAX's caches (``jax.clear_caches()``, then ``gc.collect()``) when this process holds
    more than ``share`` of the limit; True when it did. Later calls compile their programs again
    (seconds each); nothing happens where the count or the limit is unknown."""
    count, limit = map_count(), map_limit()
    if count is None or limit is None or count <= share * limit:
        return False
    jax.clear_caches()
    gc.collect()
    return True
