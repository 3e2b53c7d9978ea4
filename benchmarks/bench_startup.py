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

Each process is timed in wall seconds and in CPU seconds (user + system, all its threads, from
``getrusage``): on a shared machine the wall time follows the other processes' load, the CPU time
much less. Each round also runs one ``breakdown`` process (not among the timed ones): a warm fit
that stamps wall and CPU time after ``import jax``, after importing the command, around reading
the recording and around each kept program (:func:`jadhesion.cli.fit_program._kept`: load,
lowering, cache look-up, execution); it leaves as the ``jadhesion`` program does
(:func:`jadhesion.cli.leave`), and the interpreter's start and exit are measured from outside. It
also records whether ``scipy`` was imported (JAX's CPU LAPACK set-up imports it; the kept fit
programs hold no LAPACK call, so a warm fit should not).

The recording is simulated once (2 000 samples, ``jadhesion simulate``). Results go to
``benchmarks/results/bench_startup.json`` with the git commit, the settings and the load average
before and after. Run as ``python -m benchmarks.bench_startup [--repeats 7] [--method lm]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.provenance import commit

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_startup.json"


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed_process(argv, env) -> tuple[float, float]:
    """Wall and CPU seconds of one process."""
    cpu, start = _children_cpu(), time.perf_counter()
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=900)
    return time.perf_counter() - start, _children_cpu() - cpu


#: The breakdown process: ``python -c PROBE REC METHOD``; prints one JSON line: its phases, each
#: ``[wall, cpu]`` seconds, and the script's own span (the rest is the interpreter's start and exit).
PROBE = """
import json, sys, time
t = lambda: (time.perf_counter(), time.process_time())
marks = [("start", t())]
import jax
marks.append(("import jax", t()))
import io, contextlib
from jadhesion.cli import leave, main
from jadhesion.cli import fit_program, fit_run
marks.append(("import the command", t()))
def stamp(label, fn):
    def wrapped(*a, **k):
        marks.append(("other", t()))
        out = jax.block_until_ready(fn(*a, **k))
        marks.append((label(*a), t()))
        return out
    return wrapped
fit_program._kept = stamp(lambda name, *a: "program " + name, fit_program._kept)
fit_run.load_from_args = stamp(lambda *a: "read the recording", fit_run.load_from_args)
with contextlib.redirect_stdout(io.StringIO()):
    main(["fit", sys.argv[1], "--method", sys.argv[2], "--json"])
marks.append(("other", t()))
phases = {}
for (label, (w, c)), (_, (w0, c0)) in zip(marks[1:], marks[:-1]):
    phases.setdefault(label, [0.0, 0.0])
    phases[label][0] += w - w0
    phases[label][1] += c - c0
(w0, c0), (w1, c1) = marks[0][1], marks[-1][1]
print(json.dumps({"phases": phases, "script": [w1 - w0, c1 - c0], "scipy": "scipy" in sys.modules}))
leave(0)
"""


def _breakdown(rec: Path, method: str, env) -> dict:
    """Phases of one warm fit process (wall and CPU seconds), its exit measured from outside."""
    cpu, start = _children_cpu(), time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(rec), method],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        timeout=900,
    )
    wall, cpu = time.perf_counter() - start, _children_cpu() - cpu
    doc = json.loads(out.stdout.strip().splitlines()[-1])
    phases = doc["phases"]
    # Interpreter start before the script's first line and exit after its last, lumped together.
    phases["interpreter start + exit"] = [wall - doc["script"][0], cpu - doc["script"][1]]
    return phases, doc["scipy"]


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
    timed_process(fit, warm)  # fill: compiled executables + kept programs
    timed_process(fit, traced)  # fill: the library path's compiled executables

    kinds = ("import_jax", "cold", "warm_traced", "warm_exported")
    times = {k: [] for k in kinds}
    cpu = {k: [] for k in kinds}
    breakdowns, scipy_rounds = [], []
    load_before = os.getloadavg()
    for r in range(args.repeats):
        cold = work / f"cold{r}"
        runs = {
            "import_jax": ([sys.executable, "-c", "import jax"], env),
            "cold": (fit, {**env, "JADHESION_CACHE": str(cold)}),
            "warm_traced": (fit, traced),
            "warm_exported": (fit, warm),
        }
        for k, (argv, e) in runs.items():
            wall, seconds = timed_process(argv, e)
            times[k].append(wall)
            cpu[k].append(seconds)
        phases, scipy_imported = _breakdown(rec, args.method, warm)
        breakdowns.append(phases)
        scipy_rounds.append(scipy_imported)
        shutil.rmtree(cold)
        print(
            f"round {r + 1}: " + ", ".join(f"{k} {times[k][-1]:.2f} s ({cpu[k][-1]:.2f} cpu)" for k in kinds),
            flush=True,
        )

    def paired(series):
        # Each round's own ratio (a busy machine slows a round's processes alike), then the median.
        return {
            k: statistics.median(t / b for t, b in zip(v, series["import_jax"], strict=True))
            for k, v in series.items()
        }

    medians = {k: statistics.median(v) for k, v in times.items()}
    cpu_medians = {k: statistics.median(v) for k, v in cpu.items()}
    base = medians["import_jax"]
    doc = {
        "commit": commit(),
        "settings": {
            "method": args.method,
            "samples": 2000,
            "repeats": args.repeats,
            "interleaved": True,
            "python": sys.version.split()[0],
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average_before": load_before,
            "load_average": os.getloadavg(),
        },
        "seconds": times,
        "median_s": medians,
        "ratio_to_import_jax": {k: v / base for k, v in medians.items()},
        "paired_ratio_median": paired(times),
        "cpu_seconds": cpu,
        "cpu_median_s": cpu_medians,
        "cpu_paired_ratio_median": paired(cpu),
        # Whether the warm breakdown process had imported scipy, per round.
        "warm_imported_scipy": scipy_rounds,
        # Median over rounds of each phase of a warm process: [wall, cpu] seconds.
        "warm_breakdown_median_s": {
            label: [statistics.median(b[label][i] for b in breakdowns) for i in (0, 1)]
            for label in breakdowns[0]
        },
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=2) + "\n")
    for k, v in medians.items():
        print(
            f"{k:>14}: median {v:6.2f} s  ({v / base:4.1f}x import jax; paired "
            f"{doc['paired_ratio_median'][k]:4.2f}x; cpu {cpu_medians[k]:5.2f} s, paired "
            f"{doc['cpu_paired_ratio_median'][k]:4.2f}x)"
        )
    for label, (wall, seconds) in doc["warm_breakdown_median_s"].items():
        print(f"  warm phase {label:>36}: {wall:5.3f} s wall, {seconds:5.3f} s cpu")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
