"""Sweep throughput (fits/s): batch size, device count, and single-fit loops (ours and scipy's).

    python -m benchmarks.bench_sweep [--method lm] [--seeds 16] [--chunks 4,16] [--devices 1,2]
                                     [--samples 400] [--json]

* ``sweep``: :func:`jadhesion.sweeps.run_sweep` end to end (simulate → observe → fit → peaks) on
  ``seeds`` dry-rail datasets, per chunk size, timed after a warm-up run of the same grid.
* ``devices``: the same, largest chunk, in a subprocess with ``N`` forced host devices
  (``XLA_FLAGS=--xla_force_host_platform_device_count=N``); CPU devices share the machine's cores.
* ``loop``: a Python loop of jitted :func:`fit_polach` calls on the same simulated datasets (warm).
* ``scipy``: ``scipy.optimize.least_squares`` (TRF, box [0, 1]⁵, start 0.5) in a loop on the same
  datasets, if scipy is installed — a single local LM-type start, not the global LM.

Loops time the fits only; the sweep rows include simulation. Ratios are sweep (largest chunk, one
device) over each loop.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # run from a checkout without installing


def _grid(args):
    from jadhesion.sweeps import Grid

    return Grid(scenarios=["dry"], seeds=range(args.seeds), methods=[args.method], n_samples=args.samples)


def sweep_rate(args, chunk: int) -> float:
    """Fits/s of a warm end-to-end sweep with ``chunk`` fits per batch."""
    from jadhesion.sweeps import run_sweep

    with tempfile.TemporaryDirectory() as tmp:
        run_sweep(_grid(args), Path(tmp) / "warm.csv", chunk_size=chunk)
        _, summary = run_sweep(_grid(args), Path(tmp) / "timed.csv", chunk_size=chunk)
    return summary.fits_per_second


def device_rate(args, devices: int, chunk: int) -> float:
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    cmd = [
        sys.executable,
        __file__,
        "--worker-chunk",
        str(chunk),
        "--method",
        args.method,
        "--seeds",
        str(args.seeds),
        "--samples",
        str(args.samples),
    ]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1800)
    if out.returncode != 0:
        raise RuntimeError(f"{devices}-device run failed:\n{out.stderr[-2000:]}")
    return float(out.stdout.strip().splitlines()[-1])


def loop_rates(args) -> dict:
    """Fits/s of Python loops over single fits: jitted ``fit_polach``, and scipy if installed."""
    import jax

    from jadhesion.data.simulated_datasets import simulate_batch
    from jadhesion.identify.polach_fit import fit_polach
    from jadhesion.models.polach import polach_adhesion
    from jadhesion.sweeps import fit_key

    batch = simulate_batch("dry", list(range(args.seeds)), n_samples=args.samples)
    data = [jax.tree.map(lambda a, i=i: a[i], batch) for i in range(args.seeds)]
    keys = [fit_key(i, args.method) for i in range(args.seeds)]
    fit_polach(data[0], args.method, keys[0]).params.block_until_ready()
    t0 = time.perf_counter()
    for d, k in zip(data, keys, strict=True):
        fit_polach(d, args.method, k).params.block_until_ready()
    rates = {"loop": args.seeds / (time.perf_counter() - t0)}
    try:
        from scipy.optimize import least_squares
    except ImportError:
        return rates
    residual = jax.jit(lambda th, d: polach_adhesion(th, d.creep, d.slip, d.k_eps) - d.adhesion)
    jac = jax.jit(jax.jacfwd(residual))
    residual(np.full(5, 0.5), data[0]).block_until_ready()
    jac(np.full(5, 0.5), data[0]).block_until_ready()
    t0 = time.perf_counter()
    for d in data:
        least_squares(
            lambda th, d=d: np.asarray(residual(th, d)),
            np.full(5, 0.5),
            jac=lambda th, d=d: np.asarray(jac(th, d)),
            bounds=(0.0, 1.0),
            method="trf",
        )
    rates["scipy"] = args.seeds / (time.perf_counter() - t0)
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="lm")
    parser.add_argument("--seeds", type=int, default=16)
    parser.add_argument("--chunks", default="4,16", help="comma-separated chunk sizes")
    parser.add_argument("--devices", default="1,2", help="comma-separated forced device counts")
    parser.add_argument("--samples", type=int, default=400)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--worker-chunk", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    from jadhesion.config import enable_compilation_cache, enable_x64

    enable_x64()
    enable_compilation_cache()
    if args.worker_chunk:
        print(sweep_rate(args, args.worker_chunk))
        return
    chunks = [int(c) for c in args.chunks.split(",")]
    result = {
        "method": args.method,
        "seeds": args.seeds,
        "samples": args.samples,
        "cpu_count": os.cpu_count(),
        "sweep_fits_per_s": {c: sweep_rate(args, c) for c in chunks},
        "devices_fits_per_s": {
            int(n): device_rate(args, int(n), max(chunks)) for n in args.devices.split(",")
        },
    }
    result.update({f"{k}_fits_per_s": v for k, v in loop_rates(args).items()})
    best = result["sweep_fits_per_s"][max(chunks)]
    result["ratios"] = {
        f"sweep/{k}": best / result[f"{k}_fits_per_s"]
        for k in ("loop", "scipy")
        if f"{k}_fits_per_s" in result
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    for key, value in result.items():
        print(f"{key:>20}: {value}")


if __name__ == "__main__":
    main()
