"""Loading an hour of data: a 360 000-row (1 h at 100 Hz) recording CSV read by
:func:`jadhesion.data.recording.load_recording` (validation included) and, when installed, by
pandas' CSV reader on the same file. Each reader runs in a fresh subprocess (best of 3 timed
loads; peak resident memory of that process). Run ``python -m benchmarks.bench_loading``; results in
``benchmarks/results/bench_loading.json`` with the git commit and the settings."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.provenance import commit
from jadhesion.data.recording import save_recording
from jadhesion.data.vehicle import LOCO_22E

READERS = {
    "jadhesion": "from jadhesion.data.recording import load_recording as read",
    "pandas": "from pandas import read_csv as read",
}
_CHILD = """
import resource, sys, time
{imp}
times = []
for _ in range(3):
    t0 = time.perf_counter(); read(sys.argv[1]); times.append(time.perf_counter() - t0)
print(min(times), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def _write(path: Path, rows: int) -> None:
    rng = np.random.default_rng(0)
    t = np.arange(rows) * 0.01 + rng.uniform(-1e-4, 1e-4, rows)  # 100 Hz with jitter
    v = 5.0 + 2.0 * np.sin(t / 60.0)
    torque = 0.25 * LOCO_22E.axle_weight_n * LOCO_22E.wheel_radius_m * np.ones(rows)
    save_recording(
        {"time": t, "vehicle_speed": v, "wheel_speed": v * 1.01, "traction_torque": torque}, LOCO_22E, path
    )


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=360_000)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.csv"
        _write(path, args.rows)
        results = {}
        for name, imp in READERS.items():
            proc = subprocess.run(
                [sys.executable, "-c", _CHILD.format(imp=imp), str(path)], capture_output=True, text=True
            )
            if proc.returncode != 0:
                results[name] = {"skipped": proc.stderr.strip().splitlines()[-1]}
                continue
            seconds, peak_mb = map(float, proc.stdout.split())
            results[name] = {"seconds": seconds, "peak_rss_mb": peak_mb}
        size_mb = path.stat().st_size / 2**20
    doc = {"commit": commit(), "rows": args.rows, "file_mb": size_mb, "results": results}
    out = Path(__file__).parent / "results" / "bench_loading.json"
    out.write_text(json.dumps(doc, indent=2) + "\n")
    print(json.dumps(doc, indent=2))
    return doc


if __name__ == "__main__":
    main()
