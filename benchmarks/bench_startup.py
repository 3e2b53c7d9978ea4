"""Start-up of a new ``jadhesion fit`` process (issue #16 item 4): wall time against a bare
``python -c "import jax"``.

Four kinds of process, run interleaved (one of each per round, so a busy machine slows all alike),
``--repeats`` rounds, medians reported:

* ``import_jax``: ``python -c "import jax"``, the yardstick;
* ``cold``: ``jadhesion fit REC --method lm --json`` with an empty cache folder;
* ``warm_traced``: a second run with the compilation cache warm and kept programs turned off
  (``JADHESION_PROGRAMS=0``: the path before kept programs — import the library, compute ``k_eps``
  eagerly, trace and lower the fit);
* ``warm_exported``: a second run with the kept exported program (the fast path).

The recording is simulated once (2 000 samples, ``jadhesion simulate``). Results go to
``benchmarks/results/bench_startup.json`` with the git commit and the settings. Run as
``python -m benchmarks.bench_startup [--repeats 7] [--method lm]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_startup.json"


def _timed(argv, env) -> float:
    start = time.perf_counter()
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=900)
    return time.perf_counter() - start


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        return out.stdout.strip() + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="interleaved rounds (default 7, >= 5)")
    parser.add_argument("--method", default="lm", help="fit method (default lm)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)

    work = Path(tempfile.mkdtemp(prefix="jadhesion-bench-startup-"))
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
    }
    jad = [sys.executable, "-m", "jadhesion"]
    rec = work / "rec.csv"
    subprocess.run(
        [*jad, "simulate", "--out", str(rec), "--json"],
        env={**env, "JADHESION_CACHE": str(work / "sim")},
        check=True,
        stdout=subprocess.DEVNULL,
        timeout=900,
    )
    fit = [*jad, "fit", str(rec), "--method", args.method, "--json"]
    warm_cache = work / "warm"
    warm = {**env, "JADHESION_CACHE": str(warm_cache)}
    traced = {**warm, "JADHESION_PROGRAMS": "0"}
    _timed(fit, warm)  # fill: compiled executables + kept programs
    _timed(fit, traced)  # fill: the library path's compiled executables

    times = {k: [] for k in ("import_jax", "cold", "warm_traced", "warm_exported")}
    for r in range(args.repeats):
        cold = work / f"cold{r}"
        times["import_jax"].append(_timed([sys.executable, "-c", "import jax"], env))
        times["cold"].append(_timed(fit, {**env, "JADHESION_CACHE": str(cold)}))
        times["warm_traced"].append(_timed(fit, traced))
        times["warm_exported"].append(_timed(fit, warm))
        shutil.rmtree(cold)
        print(f"round {r + 1}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in times.items()), flush=True)

    medians = {k: statistics.median(v) for k, v in times.items()}
    base = medians["import_jax"]
    doc = {
        "commit": _commit(),
        "settings": {
            "method": args.method,
            "samples": 2000,
            "repeats": args.repeats,
            "interleaved": True,
            "python": sys.version.split()[0],
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average": os.getloadavg(),
        },
        "seconds": times,
        "median_s": medians,
        "ratio_to_import_jax": {k: v / base for k, v in medians.items()},
        # Each round's own ratio (a busy machine slows a round's processes alike), then the median.
        "paired_ratio_median": {
            k: statistics.median(t / b for t, b in zip(v, times["import_jax"], strict=True))
            for k, v in times.items()
        },
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=2) + "\n")
    for k, v in medians.items():
        print(
            f"{k:>14}: median {v:6.2f} s  ({v / base:4.1f}x import jax; paired "
            f"{doc['paired_ratio_median'][k]:4.2f}x)"
        )
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
