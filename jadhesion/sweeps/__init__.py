"""Vectorised parameter sweeps: a declarative grid → simulate → observe → fit, one chunk per device.

    from jadhesion.sweeps import Grid, run_sweep
    table, summary = run_sweep(Grid(scenarios=["dry"], seeds=range(8), methods=["lm"],
                                    noise_scale=[0.5, 1, 2], creep_max=[0.05, 0.2, float("inf")]),
                               "sweep.csv", chunk_size=64)

One row per fit (columns: :data:`COLUMNS`). Scales from one core (vmap) to all local devices
(one whole chunk per device, chunks side by side) to many machines (``jax.distributed``: chunks
dealt round-robin to processes, merged by process 0); chunks are streamed to part files keyed on
the grid and the code (:func:`code_hash`), and a rerun resumes. Every chunk runs the same program
whatever the device count or process split, so the table is the same bit for bit.
"""

from .compute import fit_key, observe
from .grid import METHODS, Chunk, Grid, grid_hash, plan
from .provenance import code_hash, source_digest
from .runner import SweepSummary, merge, parts_dir, run_sweep
from .table import COLUMNS, read_table, write_table

__all__ = [
    "COLUMNS",
    "METHODS",
    "Chunk",
    "Grid",
    "SweepSummary",
    "code_hash",
    "fit_key",
    "grid_hash",
    "merge",
    "observe",
    "parts_dir",
    "plan",
    "read_table",
    "run_sweep",
    "source_digest",
    "write_table",
]
