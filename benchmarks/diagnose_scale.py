"""Seconds and peak memory of ``jadhesion diagnose`` against recording length.

For each length a recording is written to CSV — our simulator's (dry, seed 0,
``sensors="realistic"``; its recordings do not coast) or, with ``--generator foreign``, the
independent generator's (:mod:`validation.foreign_generator`: seed 3, ``sensor="realistic"``, 50 Hz,
its own profile with coasting gaps, so the null takes its coasting path and re-smooths every
replica's raw speeds) — and a fresh process then runs the CLI's code path on it (load, selection,
diagnosis with the null's replicas) and reports its wall time and peak resident memory
(``ru_maxrss``, the whole process: Python, JAX, the compiled programs and the data), and its CPU
seconds (all threads; less sensitive than wall time to the other jobs on the 2 shared cores). Each
length runs twice on a fresh compilation cache: ``cold`` (compiles and fills the cache, as a user's
first run) and ``warm`` (reads it, as every later run), reported apart (``--starts cold`` runs the
first only). The result file records the commit, the settings and the load average.

    python -m benchmarks.diagnose_scale [--lengths 5000,20000,60000,180000] [--replicas 19]
        [--generator ours|foreign] [--starts cold,warm]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.diagnose_blind import commit

RESULTS = Path(__file__).resolve().parent / "results"
CHILD = """
import json, resource, sys, time
from jadhesion.config import enable_compilation_cache, enable_x64
enable_x64(); enable_compilation_cache()
from jadhesion.cli.diagnose_run import diagnose_file
start = time.perf_counter()
cpu = time.process_time()
result, _ = diagnose_file(sys.argv[1], replicas=int(sys.argv[2]))
print(json.dumps({"seconds": time.perf_counter() - start, "cpu_seconds": time.process_time() - cpu,
    "verdict": result["verdict"],
    "used": result["selection"]["used"],
    "null_path": (result["null"] or {}).get("noise", {}).get("error", {}).get("source"),
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""
WRITE = """
import sys
from jadhesion.config import enable_x64
enable_x64()
from jadhesion.data.recording import save_recording
from jadhesion.data.simulator import simulate
sim = simulate("dry", 0, (), int(sys.argv[2]))
raw = {k: sim.columns[k] for k in ("time", "vehicle_speed", "wheel_speed", "traction_torque")}
save_recording(raw, sim.vehicle, sys.argv[1])
"""
WRITE_FOREIGN = """
import sys
from validation.foreign_generator import generate, write
n = int(sys.argv[2])
write(generate(3, sensor="realistic", rate_hz=50.0, duration_s=(n - 1) / 50.0), sys.argv[1], truth=False)
"""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lengths", default="5000,20000,60000,180000")
    parser.add_argument("--replicas", type=int, default=19)
    parser.add_argument("--generator", choices=("ours", "foreign"), default="ours")
    parser.add_argument("--starts", default="cold,warm", help="cold, warm or both (cold first)")
    parser.add_argument("--out", default=str(RESULTS / "diagnose_scale.json"))
    args = parser.parse_args(argv)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    rows, head = [], commit()
    write = WRITE if args.generator == "ours" else WRITE_FOREIGN
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(x) for x in args.lengths.split(",")):
            path = str(Path(tmp) / f"rec_{n}.csv")
            subprocess.run([sys.executable, "-c", write, path, str(n)], check=True, env=env)
            cache = {**env, "JADHESION_CACHE": str(Path(tmp) / f"cache_{n}")}
            for start in args.starts.split(","):
                out = subprocess.run(
                    [sys.executable, "-c", CHILD, path, str(args.replicas)],
                    check=True,
                    env=cache,
                    capture_output=True,
                    text=True,
                ).stdout
                row = {
                    "samples": n,
                    "start": start,
                    **json.loads(out.strip().splitlines()[-1]),
                    "loadavg": os.getloadavg(),
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
                doc = {"commit": head, "settings": vars(args), "rows": rows}
                Path(args.out).write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
