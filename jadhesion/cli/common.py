"""Shared pieces of the command line: user errors, JSON output, progress bars on stderr.

JAX-free (argparse definitions import it, and ``--help`` must not start JAX): it imports only the
standard library and jadhesion's foundations (tqdm when a progress bar is made).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from ..errors import InputError as UserError  # noqa: F401  (re-exported for command modules)
from ..report.text import table  # noqa: F401  (re-exported for command modules)


def require_at_least(command: str, least: int, **flags) -> None:
    """Raise :class:`UserError` for the first ``--flag`` (given, not None) whose value is below
    ``least``, e.g. ``require_at_least("sweep", 1, seeds=args.seeds)``."""
    for name, value in flags.items():
        if value is not None and value < least:
            raise UserError(f"{command}: --{name.replace('_', '-')} must be >= {least}, got {value}")


#: The largest ``--seed`` of every command: NumPy's ``default_rng`` takes any integer >= 0 and
#: ``jax.random.key`` any int64 (the command line runs JAX in x64), so seeds are [0, 2**63 - 1].
SEED_MAX = 2**63 - 1


def require_in_range(command: str, lo, hi, **flags) -> None:
    """Raise :class:`UserError` for the first ``--flag`` (given, not None) outside ``[lo, hi]``
    (NaN included), e.g. ``require_in_range("simulate", 0.0, 10.0, sensor_noise=args.sensor_noise)``."""
    for name, value in flags.items():
        if value is not None and not lo <= value <= hi:
            raise UserError(f"{command}: --{name.replace('_', '-')} must be in [{lo}, {hi}], got {value}")


def require_seed(command: str, seed) -> None:
    """``--seed`` in [0, :data:`SEED_MAX`], the one rule of every command's seed."""
    require_in_range(command, 0, SEED_MAX, seed=seed)


#: The largest ``--max-iter`` of a population method (300 by default; a fit stops earlier when
#: its best MAE stalls): beyond int64 the loop's counter overflowed in JAX.
MAX_ITER = 1_000_000
#: The most memory one evaluation of a population may take, population × samples (× fits batched
#: together) × 8 B: each evaluation makes such an array (the process's peak grew by about that,
#: measured), and --pop-size 10**8 asked XLA for 844 GB.
MAX_POPULATION_BYTES = 2**30


def require_population_memory(command: str, pop_size: int, samples: int, where: str) -> None:
    """Raise :class:`UserError` naming ``--pop-size`` when ``pop_size`` members × ``samples``
    values (``where`` says whose) exceed :data:`MAX_POPULATION_BYTES`."""
    need = pop_size * samples * 8
    if need > MAX_POPULATION_BYTES:
        raise UserError(
            f"{command}: --pop-size {pop_size} {where} needs {need / 2**30:.3g} GiB per evaluation of the "
            f"population, more than {MAX_POPULATION_BYTES / 2**30:g} GiB: use --pop-size "
            f"{MAX_POPULATION_BYTES // (8 * samples)} or less"
        )


def require_output_file(command: str, value, suffixes=(".csv",)) -> None:
    """Raise :class:`UserError` unless ``--out FILE`` names a file of one of ``suffixes`` (``.csv``
    in any case, others exactly, as the writers match them) in an existing directory, and not a
    directory. ``command`` prefixes the message (``""``: none)."""
    out, prefix = Path(value), f"{command}: " if command else ""
    if not (out.suffix in suffixes or (".csv" in suffixes and out.suffix.lower() == ".csv")):
        raise UserError(f"{prefix}--out {value}: expected a {' or '.join(suffixes)} file name")
    if not out.parent.is_dir():
        raise UserError(f"{prefix}--out {value}: directory {str(out.parent)!r} does not exist")
    if out.is_dir():
        raise UserError(f"{prefix}--out {value}: is a directory")


def require_output_dir(command: str, flag: str, value) -> None:
    """Raise :class:`UserError` unless ``--flag DIR`` (given, not None) can hold the command's
    files: a directory, or a missing one whose nearest existing ancestor is a directory. Checked
    before any work, so a bad one never wastes it or leaves other outputs half written."""
    if value is None:
        return
    path = Path(value)
    existing = next(p for p in (path, *path.parents) if p.exists())
    if not existing.is_dir():
        where = "exists" if existing == path else f"{existing} exists"
        raise UserError(f"{command}: --{flag} {value}: {where} and is not a directory")


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if hasattr(obj, "tolist"):
        return _plain(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def say_written(paths) -> None:
    """``wrote PATH`` on stdout for each file a command wrote (its JSON lists them as ``plots``)."""
    for path in paths:
        print(f"wrote {path}")


def emit_json(document) -> None:
    """Write one JSON document on stdout (NumPy/JAX values converted; NaN/inf become null)."""
    json.dump(_plain(document), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")
    sys.stdout.flush()


class Progress:
    """A progress bar on stderr (tqdm), drawn only when stderr is a terminal (and ``enabled``), so
    long work shows a live bar at a terminal and nothing in a log or a pipe.

    Pass it to the library as its progress callback, ``progress(done, total)`` — units finished so
    far and units in all — or count by hand with :meth:`update`. Use it as a context manager (or
    call :meth:`close`) to end the bar's line.
    """

    def __init__(self, total=None, label: str = "", unit: str = "it", enabled: bool = True):
        # Imported here, not at the top: tqdm costs every command process about 0.03 s (measured,
        # benchmarks/bench_startup.py) and only long commands draw a bar.
        from tqdm import tqdm

        self.done = 0
        self.bar = tqdm(
            total=total,
            desc=label,
            unit=unit,
            file=sys.stderr,
            dynamic_ncols=True,
            disable=None if enabled else True,
        )

    def __call__(self, done: int, total: int) -> None:
        self.bar.total = total
        self.update(done - self.done)

    def update(self, n: int = 1) -> None:
        """Count ``n`` more units."""
        self.done += n
        self.bar.update(n)

    def close(self) -> None:
        """End the bar (its last state stays on the terminal)."""
        self.bar.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
