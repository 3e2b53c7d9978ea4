"""Run a grid: chunks streamed to part files, resumable, split over processes, merged into a table.

Part files live in ``<out>.parts/<grid hash>/chunk-NNNNNN.csv``; a part that exists is finished
(parts are written atomically), so a rerun of the same grid and chunk size skips it.

Across machines the sweep uses JAX's multi-controller runtime only for the process index and count
and for one barrier: process ``i`` of ``P`` runs chunks ``i, i+P, …`` on its own local devices (no
cross-process collective inside the fits), writes its parts, waits at the barrier, and process 0
merges all parts into ``out``. This needs a file system shared by the processes (the usual cluster
scratch or home directory); without one, run each process and then :func:`merge` where the parts
were gathered.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import InputError
from ..models.polach import PARAM_NAMES
from .compute import run_chunk
from .grid import Grid, grid_hash, plan
from .table import COLUMNS, check_format, concat, read_table, write_table


class SweepSummary(NamedTuple):
    """What a run did. ``fits``: grid size; ``computed``: fits this process ran now (not resumed);
    ``fits_per_second``: ``computed / seconds``; ``devices``: all devices of all processes."""

    fits: int
    computed: int
    chunks: int
    chunks_computed: int
    seconds: float
    fits_per_second: float
    devices: int
    processes: int
    out: Optional[str]
    parts: str


def _source_name(simulate) -> str:
    return "" if simulate is None else f"{simulate.__module__}.{simulate.__qualname__}"


def parts_dir(out, grid: Grid, chunk_size: int, simulate=None) -> Path:
    """Where the part files of this grid, chunk size and dataset source live."""
    out = Path(out)
    return out.with_name(out.name + ".parts") / grid_hash(grid, chunk_size, _source_name(simulate))


def _part(parts: Path, index: int) -> Path:
    return parts / f"chunk-{index:06d}.csv"


def _true_theta(scenario):
    from ..data.scenarios import SCENARIOS

    return jnp.asarray(SCENARIOS[scenario].params, dtype=float)


def simulate_grid(grid: Grid, scenario: str, seeds):
    """The default dataset source: :func:`simulate_batch` of ``scenario`` at ``grid.n_samples``."""
    from ..data.simulator import simulate_batch

    return simulate_batch(scenario, seeds, n_samples=grid.n_samples)


def _compute(grid: Grid, chunk, chunk_size: int, simulate, devices) -> dict:
    """Simulate the chunk's distinct seeds (padded to a fixed count), observe and fit its points."""
    seed_ix, noise_ix, creep_ix = chunk.points.T
    distinct = np.unique(seed_ix)
    count = min(len(grid.seeds), -(-(chunk_size - 1) // grid.per_seed) + 1)
    padded = np.concatenate([distinct, np.full(count - len(distinct), distinct[-1])])
    seeds = np.asarray(grid.seeds, dtype=np.int64)
    data = (simulate or simulate_grid)(grid, chunk.scenario, seeds[padded])
    theta = _true_theta(chunk.scenario)
    noise = np.asarray(grid.noise_scale)[noise_ix]
    creep = np.asarray(grid.creep_max)[creep_ix]
    res = run_chunk(chunk.method, data, theta, np.searchsorted(distinct, seed_ix), seeds[seed_ix],
                    noise, creep, size=chunk_size, options=grid.fit_options, devices=devices)
    m = len(seed_ix)
    table = dict(scenario=np.full(m, chunk.scenario), method=np.full(m, chunk.method),
                 seed=seeds[seed_ix], noise_scale=noise, creep_max=creep)
    table.update({f"true_{p}": np.full(m, float(t)) for p, t in zip(PARAM_NAMES, np.asarray(theta))})
    table.update({p: res["params"][:, j] for j, p in enumerate(PARAM_NAMES)})
    table.update({k: v for k, v in res.items() if k != "params"})
    return table


def run_sweep(grid: Grid, out, *, chunk_size: int = 64, resume: bool = True,
              progress: bool = False, simulate=None, devices=None) -> tuple:
    """Run every fit of ``grid``; write the merged table to ``out`` (``.csv`` or ``.parquet``).

    Each chunk is one jitted, vmapped program sharded over ``devices`` (default: this process's
    local devices). Under ``jax.distributed`` the chunks are dealt round-robin to the processes and
    process 0 writes ``out`` after a barrier. The table's ``seconds`` column is the per-fit share
    of its chunk's wall time (simulation, compilation on a shape's first chunk, fit, peaks).

    ``simulate(grid, scenario, seeds) -> PolachDataset`` (stacked over ``seeds``) replaces the
    default source :func:`simulate_grid`; it must be a module-level function (its name enters the
    part files' hash) and return the same shapes for every call of a sweep.

    Returns:
        ``(table, summary)``: the table as a dict of columns (``None`` on processes other than 0)
        and a :class:`SweepSummary`.
    """
    start = time.perf_counter()
    check_format(out)
    chunks = plan(grid, chunk_size)
    parts = parts_dir(out, grid, chunk_size, simulate)
    parts.mkdir(parents=True, exist_ok=True)
    rank, size = jax.process_index(), jax.process_count()
    mine = chunks[rank::size]
    todo = [c for c in mine if not (resume and _part(parts, c.index).exists())]
    if rank == 0:
        manifest = dict(grid=grid.to_dict(), chunk_size=chunk_size, chunks=len(chunks), columns=COLUMNS)
        (parts / "grid.json").write_text(json.dumps(manifest, indent=1))
    from ..cli.common import Progress

    bar = Progress(sum(len(c.points) for c in todo), "sweep", "fits", enabled=progress)
    for chunk in todo:
        t0 = time.perf_counter()
        table = _compute(grid, chunk, chunk_size, simulate, devices)
        table["seconds"] = np.full(len(chunk.points), (time.perf_counter() - t0) / len(chunk.points))
        write_table(table, _part(parts, chunk.index))
        bar.update(len(chunk.points))
    computed = sum(len(c.points) for c in todo)
    if size > 1:
        from jax.experimental.multihost_utils import sync_global_devices

        sync_global_devices(f"jadhesion.sweep.{parts.name}")
    table = merge(grid, out, chunk_size, simulate) if rank == 0 else None
    seconds = time.perf_counter() - start
    summary = SweepSummary(grid.size, computed, len(chunks), len(todo), seconds,
                           computed / seconds if seconds > 0 else math.nan, jax.device_count(), size,
                           str(out) if rank == 0 else None, str(parts))
    return table, summary


def merge(grid: Grid, out, chunk_size: int, simulate=None) -> dict:
    """Concatenate the grid's part files in chunk order and write ``out``; returns the table."""
    parts = parts_dir(out, grid, chunk_size, simulate)
    chunks = plan(grid, chunk_size)
    missing = [c.index for c in chunks if not _part(parts, c.index).exists()]
    if missing:
        raise InputError(f"sweep: {len(missing)} chunk(s) missing in {parts} (first {missing[0]})")
    table = concat(read_table(_part(parts, c.index)) for c in chunks)
    write_table(table, out)
    return table
