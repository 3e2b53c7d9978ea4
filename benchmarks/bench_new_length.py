"""A recording of a *new length* with a warm cache: does a new process load its programs or compile?

XLA compiles one program per array shape. The commands pad their datasets to a length bucket
(:mod:`jadhesion.data.length_buckets`) so that every length of a bucket shares the bucket's
programs; what runs on the exact length compiles again for each new one. For each command this
times, in a new process each (wall and CPU seconds, all threads):

* ``cold``: the first recording (2 000 samples) on an empty cache folder (compiles and fills it);
* ``new_length``: a recording of another length of the same bucket (1 960, 1 920, … samples: one
  per round), the cache warm from the runs before;
* ``same_length``: that recording again (everything loaded).

``new_length − same_length`` is what the command still compiles per length. Rounds are
interleaved over the commands (a busy machine slows all alike); medians are reported. Recordings
are our simulator's (dry, realistic sensors, ``jadhesion simulate --duration``). Results go to
``benchmarks/results/bench_new_length.json`` with the commit, the settings and the load average.

    python -m benchmarks.bench_new_length [--rounds 3] [--commands fit,posterior,online,diagnose]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.bench_startup import timed_process
from benchmarks.provenance import commit

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_new_length.json"
#: Each command's arguments after the recording (the posterior short: its compile, not its chain).
ARGS = {
    "fit": ["--method", "lm", "--json"],
    "posterior": ["--walkers", "16", "--steps", "120", "--json"],
    "online": ["--json"],
    "diagnose": ["--json"],
}
RATE_HZ, FIRST, STEP = 50.0, 2000, 40


def _timed(argv, env) -> dict:
    """Wall and CPU seconds of one process (:func:`.bench_startup.timed_process`)."""
    return dict(zip(("wall", "cpu"), timed_process(argv, env), strict=True))


def _recording(folder: Path, samples: int, seed: int, env) -> Path:
    path = folder / f"dry_{samples}.csv"
    duration = (samples - 1) / RATE_HZ
    argv = [sys.executable, "-m", "jadhesion", "simulate", "--scenario", "dry", "--seed", str(seed)]
    argv += ["--duration", f"{duration:.6f}", "--out", str(path)]
    subprocess.run(argv, env=env, check=True, capture_output=True, timeout=600)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--commands", default=",".join(ARGS))
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args(argv)
    commands = args.commands.split(",")
    unknown = [c for c in commands if c not in ARGS]
    if unknown or args.rounds < 1:
        parser.error(f"unknown command(s) {unknown}" if unknown else "--rounds must be >= 1")
    load_before = os.getloadavg()
    runs = {c: {"cold": [], "new_length": [], "same_length": []} for c in commands}
    lengths = [FIRST - STEP * (r + 1) for r in range(args.rounds)]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        env = {**os.environ, "JADHESION_CACHE": str(folder / "cache"), "PYTHONPATH": str(ROOT)}
        first = _recording(folder, FIRST, 0, env)
        others = [_recording(folder, n, r + 1, env) for r, n in enumerate(lengths)]
        jadhesion = [sys.executable, "-m", "jadhesion"]
        for c in commands:
            runs[c]["cold"].append(_timed([*jadhesion, c, str(first), *ARGS[c]], env))
        for path in others:
            for c in commands:
                for kind in ("new_length", "same_length"):
                    took = _timed([*jadhesion, c, str(path), *ARGS[c]], env)
                    runs[c][kind].append(took)
                    print(f"{c:10s} {path.stem:10s} {kind:12s} {took['wall']:6.2f} s", flush=True)
    median = {
        c: {k: {u: statistics.median(r[u] for r in v) for u in ("wall", "cpu")} for k, v in kinds.items()}
        for c, kinds in runs.items()
    }
    doc = {
        "commit": commit(),
        "settings": {
            "rounds": args.rounds,
            "commands": {c: ARGS[c] for c in commands},
            "first_samples": FIRST,
            "new_lengths": lengths,
            "rate_hz": RATE_HZ,
            "recordings": "jadhesion simulate --scenario dry (realistic sensors), seeds 0, 1, ...",
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "load_average_before": load_before,
            "load_average": os.getloadavg(),
        },
        "seconds": runs,
        "median_s": median,
        "per_length_s": {c: m["new_length"]["wall"] - m["same_length"]["wall"] for c, m in median.items()},
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(doc, indent=1))
    for c in commands:
        m = median[c]
        print(
            f"{c:10s} cold {m['cold']['wall']:6.2f} s, new length {m['new_length']['wall']:6.2f} s, "
            f"same length {m['same_length']['wall']:6.2f} s (wall; CPU {m['new_length']['cpu']:.2f} / "
            f"{m['same_length']['cpu']:.2f} s)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
