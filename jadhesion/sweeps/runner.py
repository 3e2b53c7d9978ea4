"""Run a grid: chunks streamed to part files, resumable, split over processes, merged into a table.

Part files live in ``<out>.parts/<hash>/chunk-NNNNNN.csv``, the hash naming the grid, the chunk
size, the dataset source and the code that computes them (:func:`.provenance.code_hash`); a part
that exists is finished (parts are written atomically), so a rerun of the same grid, chunk size and
code skips it, and a rerun after a code change recomputes everything into a fresh folder.

Within a process, chunks are dealt to the local devices, one whole chunk per device at a time
(:mod:`.compute`), so each chunk's numbers do not depend on the device count. Across machines the
sweep uses JAX's multi-controller runtime only for the process index and count and for one
barrier: process ``i`` of ``P`` runs chunks ``i, i+P, …`` on its own local devices (no
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
from typing import Callable, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental.multihost_utils import sync_global_devices

from ..data.scenarios import SCENARIOS
from ..data.simulated_datasets import simulate_batch
from ..errors import InputError
from ..models.polach import PARAM_NAMES
from ..status import status_labels
from .compute import finish_chunk, start_chunk
from .grid import Grid, grid_hash, plan
from .provenance import code_hash
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


def parts_dir(out, grid: Grid, chunk_size: int, simulate=None, devices=None) -> Path:
    """Where the part files of this grid, chunk size, dataset source and code live (``devices``:
    the devices computing them, default ``jax.local_devices()``, enter through their kind)."""
    out = Path(out)
    digest = grid_hash(grid, chunk_size, _source_name(simulate), code_hash(simulate, devices))
    return out.with_name(out.name + ".parts") / digest


def _part(parts: Path, index: int) -> Path:
    return parts / f"chunk-{index:06d}.csv"


def simulate_grid(grid: Grid, scenario: str, seeds):
    """The default dataset source: :func:`simulate_batch` of ``scenario`` at ``grid.n_samples``."""
    return simulate_batch(scenario, seeds, n_samples=grid.n_samples)


class _Started(NamedTuple):
    chunk: object
    coordinates: dict
    outputs: dict


def _start(grid: Grid, chunk, chunk_size: int, simulate, device) -> _Started:
    """Simulate the chunk's distinct seeds (padded to a fixed count) on ``device`` and dispatch its
    observe → fit → peak program there."""
    seed_ix, noise_ix, creep_ix = chunk.points.T
    distinct = np.unique(seed_ix)
    count = min(len(grid.seeds), -(-(chunk_size - 1) // grid.per_seed) + 1)
    padded = np.concatenate([distinct, np.full(count - len(distinct), distinct[-1])])
    seeds = np.asarray(grid.seeds, dtype=np.int64)
    with jax.default_device(device):
        data = (simulate or simulate_grid)(grid, chunk.scenario, seeds[padded])
    theta = np.asarray(SCENARIOS[chunk.scenario].params, dtype=float)
    noise = np.asarray(grid.noise_scale)[noise_ix]
    creep = np.asarray(grid.creep_max)[creep_ix]
    outputs = start_chunk(
        chunk.method,
        data,
        jnp.asarray(theta),
        np.searchsorted(distinct, seed_ix),
        seeds[seed_ix],
        noise,
        creep,
        size=chunk_size,
        options=grid.fit_options,
        device=device,
    )
    m = len(seed_ix)
    coordinates = dict(
        scenario=np.full(m, chunk.scenario),
        method=np.full(m, chunk.method),
        seed=seeds[seed_ix],
        noise_scale=noise,
        creep_max=creep,
    )
    coordinates.update({f"true_{p}": np.full(m, t) for p, t in zip(PARAM_NAMES, theta, strict=True)})
    return _Started(chunk, coordinates, outputs)


def _finish(started: _Started) -> dict:
    """The chunk's table (without ``seconds``), once its program has run."""
    res = finish_chunk(started.outputs, len(started.chunk.points))
    table = dict(started.coordinates)
    table.update({p: res["params"][:, j] for j, p in enumerate(PARAM_NAMES)})
    table.update({k: v for k, v in res.items() if k not in ("params", "status")})
    table["status"] = np.asarray(status_labels(res["status"]))
    return table


def run_sweep(
    grid: Grid,
    out,
    *,
    chunk_size: int = 64,
    resume: bool = True,
    progress: Optional[Callable[[int, int], None]] = None,
    simulate=None,
    devices=None,
) -> tuple:
    """Run every fit of ``grid``; write the merged table to ``out`` (``.csv`` or ``.parquet``).

    Each chunk is one jitted, vmapped program of ``chunk_size`` points on one device; this
    process's chunks are dealt to ``devices`` (default: its local devices) in rounds of one chunk
    per device, which run concurrently. Under ``jax.distributed`` the chunks are dealt round-robin
    to the processes and process 0 writes ``out`` after a barrier. The table's ``seconds`` column is
    the per-fit share of the wall time of the round that computed it (simulation, compilation on a
    shape's first chunk, fit, peaks), so the column sums to the time spent computing.

    ``simulate(grid, scenario, seeds) -> PolachDataset`` (stacked over ``seeds``) replaces the
    default source :func:`simulate_grid`; it must be a module-level function (its name and its
    module's source enter the part files' hash) and return the same shapes for every call of a
    sweep. ``progress(done, total)``, if given, is called each time a chunk's part is written,
    with the fits this process has computed so far and the fits it has to compute.

    Returns:
        ``(table, summary)``: the table as a dict of columns (``None`` on processes other than 0)
        and a :class:`SweepSummary`.
    """
    start = time.perf_counter()
    check_format(out)
    devices = list(jax.local_devices() if devices is None else devices)
    chunks = plan(grid, chunk_size)
    parts = parts_dir(out, grid, chunk_size, simulate, devices)
    parts.mkdir(parents=True, exist_ok=True)
    rank, size = jax.process_index(), jax.process_count()
    mine = chunks[rank::size]
    todo = [c for c in mine if not (resume and _part(parts, c.index).exists())]
    if rank == 0:
        manifest = dict(
            grid=grid.to_dict(),
            chunk_size=chunk_size,
            chunks=len(chunks),
            columns=COLUMNS,
            code=code_hash(simulate, devices),
        )
        (parts / "grid.json").write_text(json.dumps(manifest, indent=1))
    computed, total = 0, sum(len(c.points) for c in todo)
    for first in range(0, len(todo), len(devices)):
        t0 = time.perf_counter()
        round_ = zip(todo[first:], devices, strict=False)  # the last round may leave devices idle
        started = [_start(grid, c, chunk_size, simulate, d) for c, d in round_]
        tables = [_finish(s) for s in started]
        share = (time.perf_counter() - t0) / sum(len(s.chunk.points) for s in started)
        for s, table in zip(started, tables, strict=True):
            table["seconds"] = np.full(len(s.chunk.points), share)
            write_table(table, _part(parts, s.chunk.index))
            computed += len(s.chunk.points)
            if progress:
                progress(computed, total)
    if size > 1:
        sync_global_devices(f"jadhesion.sweep.{parts.name}")
    table = merge(grid, out, chunk_size, simulate, devices) if rank == 0 else None
    seconds = time.perf_counter() - start
    summary = SweepSummary(
        grid.size,
        computed,
        len(chunks),
        len(todo),
        seconds,
        computed / seconds if seconds > 0 else math.nan,
        jax.device_count(),
        size,
        str(out) if rank == 0 else None,
        str(parts),
    )
    return table, summary


def merge(grid: Grid, out, chunk_size: int, simulate=None, devices=None) -> dict:
    """Concatenate the grid's part files in chunk order and write ``out``; returns the table."""
    parts = parts_dir(out, grid, chunk_size, simulate, devices)
    chunks = plan(grid, chunk_size)
    missing = [c.index for c in chunks if not _part(parts, c.index).exists()]
    if missing:
        raise InputError(f"sweep: {len(missing)} chunk(s) missing in {parts} (first {missing[0]})")
    table = concat(read_table(_part(parts, c.index)) for c in chunks)
    write_table(table, out)
    return table
