"""Hours of data (issue #17 item 7): ``jadhesion fit`` on recordings of 2 000, 36 000 and 360 000
rows (20 s, 6 min and 1 h at 100 Hz), stage by stage, and the CSV read against other readers.

Recordings: the simulator's dry scenario at 100 Hz (realistic sensors, seed 0), written once into
``--work`` (kept between runs). For each size and method a fresh process runs the stages of
``jadhesion fit FILE --method M`` in order — exactly the calls :mod:`jadhesion.cli.fit_run` makes
— and records each stage's wall time and peak resident memory (``VmHWM``, reset before each stage
through ``/proc/self/clear_refs``, so a stage's peak is its own; the process's peak is the
largest). Stages: ``import`` (the fit command's modules and JAX), ``load`` (read and validate the
file), ``dataset`` (selection, observer, Kalman/RTS creep smoother), ``fit`` (the kept fit program
on the padded dataset), ``trust`` (Jacobian of LM's residual over every row + HAC covariance) and
``plot`` (fit.png). Each size runs twice, cold (empty compilation cache) then warm; the warm run
is the one a user sees after the first. Also timed, best of 3 in fresh processes on the 1-hour
file: jadhesion's loader, pandas' ``read_csv`` (if installed), pyarrow's ``read_csv`` and
``numpy.loadtxt``.

Run ``python -m benchmarks.bench_hours [--methods lm itlbo] [--rows 2000 36000 360000]``; results
in ``benchmarks/results/bench_hours.json`` with the git commit, the settings and the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from .provenance import commit

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_hours.json"
RATE_HZ = 100.0
GOALS = {"load_s": 3.0, "lm_s": 10.0, "itlbo_over_lm": 3.0, "peak_mb": 2048.0}


def _peak_mb() -> float:
    status = Path("/proc/self/status").read_text()
    return int(re.search(r"VmHWM:\s+(\d+)", status).group(1)) / 1024


def _reset_peak() -> None:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:  # not Linux, or not allowed: peaks are then cumulative
        pass


def _stages(path: str, method: str) -> dict:
    """The child: ``jadhesion fit``'s stages on ``path``; ``{stage: {seconds, peak_mb}}``."""
    stages = {}
    t0 = time.perf_counter()

    def mark(name):
        nonlocal t0
        stages[name] = {"seconds": time.perf_counter() - t0, "peak_mb": _peak_mb()}
        _reset_peak()
        t0 = time.perf_counter()

    import tempfile

    import jax

    from jadhesion.cli import build_parser, fit_run
    from jadhesion.config import enable_compilation_cache, enable_x64

    mark("import")
    args = build_parser("fit").parse_args(["fit", path, "--method", method])
    enable_x64()
    enable_compilation_cache()
    recording = fit_run.load_from_args(args, Path(path))
    mark("load")
    _, dataset, selection = fit_run.load_dataset(args, Path(path), fit_run.to_dataset, recording=recording)
    jax.block_until_ready(dataset)
    mark("dataset")
    fitted = fit_run.fit_datasets(
        [dataset], method, jax.random.key(0), pop_size=50, max_iter=300, fit=fit_run.fit_polach
    )[0]
    mark("fit")
    doc = fit_run._polach_doc(args, dataset, fitted.fit, fitted.seconds)
    mark("trust")
    with tempfile.TemporaryDirectory() as tmp:
        args.plot = tmp
        fit_run._plot(args, Path(path), dataset, doc, False)
    mark("plot")
    return {
        "rows": int(len(recording.columns["time"])),
        "samples_fitted": int(dataset.adhesion.shape[0]),
        "stretches": len(selection.stretches),
        "params": doc["params"],
        "mae": doc["mae"],
        "status": doc["status"],
        "iterations": doc["iterations"],
        "stages": stages,
    }


def _simulate(path: Path, rows: int) -> None:
    from jadhesion.config import enable_x64
    from jadhesion.data.recording import save_recording
    from jadhesion.data.simulator import simulate

    enable_x64()
    result = simulate("dry", seed=0, n_samples=rows, sample_period=1.0 / RATE_HZ)
    save_recording(result.columns, result.vehicle, path)


_READERS = {
    "jadhesion": "from jadhesion.data.recording import load_recording as read",
    "pandas": "from pandas import read_csv as read",
    "pyarrow": "from pyarrow.csv import read_csv as read",
    "numpy_loadtxt": (
        "import functools, numpy; read = functools.partial(numpy.loadtxt, delimiter=',', skiprows=1)"
    ),
}
_READER_CHILD = """
import sys, time
{imp}
times = []
for _ in range(3):
    t0 = time.perf_counter(); read(sys.argv[1]); times.append(time.perf_counter() - t0)
print(min(times))
"""


def _readers(path: Path, env) -> dict:
    out = {}
    for name, imp in _READERS.items():
        proc = subprocess.run(
            [sys.executable, "-c", _READER_CHILD.format(imp=imp), str(path)],
            capture_output=True,
            text=True,
            env=env,
        )
        if proc.returncode != 0:
            out[name] = {"absent": proc.stderr.strip().splitlines()[-1]}
        else:
            out[name] = {"seconds": float(proc.stdout.split()[-1])}
    return out


def _child(path: Path, method: str, env) -> dict:
    argv = [sys.executable, "-m", "benchmarks.bench_hours", "--child", str(path), method]
    load = os.getloadavg()
    start = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT, timeout=1800)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    doc = json.loads(proc.stdout.splitlines()[-1])
    doc["process_s"] = wall
    doc["load_average_at_start"] = load
    doc["peak_mb"] = max(s["peak_mb"] for s in doc["stages"].values())
    return doc


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, nargs="+", default=[2000, 36000, 360000])
    parser.add_argument("--methods", nargs="+", default=["lm", "itlbo"])
    parser.add_argument("--work", type=Path, default=Path("/tmp/jadhesion-bench-hours"))
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--child", nargs=2, metavar=("FILE", "METHOD"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(_stages(*args.child)))
        return 0

    args.work.mkdir(parents=True, exist_ok=True)
    args.commit = commit()  # before this run writes its result file (a tracked file)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
    }
    results = {}
    for rows in args.rows:
        path = args.work / f"hour{rows}.csv"
        if not path.exists():
            _simulate(path, rows)
        cache = args.work / f"cache{rows}"
        shutil.rmtree(cache, ignore_errors=True)
        run_env = {**env, "JADHESION_CACHE": str(cache)}
        for method in args.methods:
            for phase in ("cold", "warm"):
                doc = _child(path, method, run_env)
                results.setdefault(str(rows), {}).setdefault(method, {})[phase] = doc
                table = ", ".join(
                    f"{k} {v['seconds']:.2f} s/{v['peak_mb']:.0f} MB" for k, v in doc["stages"].items()
                )
                print(
                    f"{rows} rows, {method}, {phase}: {doc['process_s']:.1f} s process; {table}", flush=True
                )
        shutil.rmtree(cache, ignore_errors=True)
        _write(args, results, env, readers=None)
    _write(args, results, env, readers=_readers(args.work / f"hour{max(args.rows)}.csv", env))
    return 0


def _summary(results) -> dict:
    """Warm runs: ``{rows: {method: {stage: [seconds, peak MB]}, "process_s", "peak_mb"}}`` and
    the goals' numbers (load and LM fit of the largest file, improved TLBO over LM)."""
    table = {}
    for rows, methods in results.items():
        table[rows] = {
            m: {
                **{k: [round(v["seconds"], 3), round(v["peak_mb"])] for k, v in r["warm"]["stages"].items()},
                "process_s": round(r["warm"]["process_s"], 2),
                "peak_mb": round(r["warm"]["peak_mb"]),
            }
            for m, r in methods.items()
            if "warm" in r
        }
        lm, itlbo = table[rows].get("lm"), table[rows].get("itlbo")
        if lm and itlbo:
            table[rows]["itlbo_fit_over_lm_fit"] = round(itlbo["fit"][0] / lm["fit"][0], 2)
    return table


def _write(args, results, env, readers) -> None:
    largest = args.work / f"hour{max(args.rows)}.csv"
    doc = {
        "commit": args.commit,
        "settings": {
            "rows": args.rows,
            "rate_hz": RATE_HZ,
            "scenario": "dry, seed 0, realistic sensors",
            "methods": args.methods,
            "python": platform.python_version(),
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average": list(os.getloadavg()),
        },
        "goals": GOALS,
        "readers_on_largest": None
        if readers is None
        else {"rows": max(args.rows), "file_mb": largest.stat().st_size / 2**20, **readers},
        "summary_warm": _summary(results),
        "results": results,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    raise SystemExit(main())
