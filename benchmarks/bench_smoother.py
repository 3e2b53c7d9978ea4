"""The creep smoother's cost (issue #18 item 5, #17 item 7) and its agreement with a reference.

**Cost.** On the recordings of :mod:`benchmarks.bench_hours` (dry scenario at 100 Hz, realistic
sensors, seed 0; 2 000, 36 000 and 360 000 rows, read from its ``--work`` folder or simulated
there), the compiled run time of :func:`jadhesion.data.creep_state.smooth_creep` — this tree's and
the reference commit's (its ``creep_state.py`` from ``git show``, imported beside ours) — and of the
LM fit of the same recording's 2 000-sample dataset (:func:`jadhesion.identify.fit_polach`,
``"lm"``, key 0, through :func:`jadhesion.data.dataset.to_dataset`). Compilation is timed apart
(``lower().compile()``); run times: the best wall time of ``--repeats`` calls of the compiled
program and their mean process CPU time (the machine is shared), with ``os.getloadavg()`` beside
each. Linear in length: seconds per row at each size.

**What a user pays: the fit command.** On the smallest recording, ``jadhesion fit FILE --json``
run in this process (:func:`jadhesion.cli.main`, warm: programs compiled or loaded, two calls
first), best wall time of ``--repeats`` calls, with the default smoothed creep (the fit, its trust
block, and the LM fit and trust block under the other slip law whose intervals it joins), with
``--single-law`` (no second law), and with ``--creep raw`` (the speeds' difference, no smoother);
and the smoother's compiled run time as a share of each. Timed after everything else: the command
turns on the persistent compilation cache, which the compile times above must not see.

**Agreement.** Reference and this tree on recordings the speed-up must not change: the simulator's
realistic sensors (dry, wet, sand) and clean ones, the foreign generator
(:mod:`validation.foreign_generator`: clean, mild and realistic sensors, jittered and quantised time
stamps), a recording given irregular time stamps (steps drawn from 0.5–1.5 × Δt) and the 1-hour
file: the chosen ``(q_v, q_w)``, the largest ``|Δ creep| / creep_sd`` and ``|Δ slip| / slip_sd``,
and the largest relative change of ``creep_sd``.

Run ``python -m benchmarks.bench_smoother [--reference REV] [--rows 2000 36000 360000]``; results in
``benchmarks/results/bench_smoother.json`` with the commit, the reference commit, the settings and
the load averages.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from jadhesion.cli import main as jadhesion_main
from jadhesion.config import enable_x64

enable_x64()

from jadhesion.data import creep_state  # noqa: E402
from jadhesion.data.dataset import to_dataset  # noqa: E402
from jadhesion.data.recording import load_recording  # noqa: E402
from jadhesion.data.simulator import simulate  # noqa: E402
from jadhesion.data.vehicle import LOCO_22E  # noqa: E402
from jadhesion.identify import fit_polach  # noqa: E402
from validation.foreign_generator import generate  # noqa: E402

from .bench_hours import _simulate  # noqa: E402
from .provenance import commit  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_smoother.json"
SIGNALS = ("time", "wheel_speed", "vehicle_speed", "traction_torque")


def reference_module(rev: str):
    """``jadhesion/data/creep_state.py`` at ``rev``, imported as ``jadhesion.data.creep_state_ref``
    (its relative imports resolve inside this tree's package); and the commit it names."""
    sha = subprocess.run(["git", "rev-parse", rev], cwd=ROOT, capture_output=True, text=True, check=True)
    source = subprocess.run(
        ["git", "show", f"{rev}:jadhesion/data/creep_state.py"], cwd=ROOT, capture_output=True, check=True
    ).stdout
    with tempfile.NamedTemporaryFile("wb", suffix=".py", delete=False) as f:
        f.write(source)
    spec = importlib.util.spec_from_file_location("jadhesion.data.creep_state_ref", f.name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    os.unlink(f.name)
    return module, sha.stdout.strip()


def _signals(columns, vehicle=LOCO_22E):
    arrays = tuple(jnp.asarray(columns[k], float) for k in SIGNALS)
    return arrays + (vehicle.wheelset_inertia_kgm2, vehicle.wheel_radius_m, vehicle.axle_load_kg)


def _best(fn, repeats: int) -> dict:
    """Best wall seconds of ``repeats`` calls of ``fn`` (already compiled), and their mean process
    CPU seconds (measured over all calls together: the kernel counts CPU time in ticks)."""
    wall = []
    c0 = time.process_time()
    for _ in range(repeats):
        w0 = time.perf_counter()
        jax.block_until_ready(fn())
        wall.append(time.perf_counter() - w0)
    cpu = (time.process_time() - c0) / repeats
    return {"wall_s": min(wall), "cpu_s": cpu, "load_average": list(os.getloadavg())}


def _time_smoother(module, args, repeats: int) -> dict:
    """Compile seconds (JAX's in-process caches cleared first: simulating a missing recording
    compiles the same program, and a cache hit timed 0.4 ms) and :func:`_best` run times."""
    jax.clear_caches()
    t0 = time.perf_counter()
    compiled = module.smooth_creep.lower(*args).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(*args))
    return {"compile_s": compile_s, **_best(lambda: compiled(*args), repeats)}


def _time_lm(recording, repeats: int) -> dict:
    data = to_dataset(recording)
    key = jax.random.key(0)
    t0 = time.perf_counter()
    fit = jax.block_until_ready(fit_polach(data, "lm", key))  # first call: tracing and compilation
    first_s = time.perf_counter() - t0
    out = {"samples": int(data.adhesion.shape[0]), "first_call_s": first_s, "status": int(fit.status)}
    return {**out, **_best(lambda: fit_polach(data, "lm", key), repeats)}


#: The fit command's variants timed by :func:`fit_command`: name → extra arguments.
FIT_VARIANTS = {
    "smoothed": [],
    "smoothed_single_law": ["--single-law"],
    "raw": ["--creep", "raw"],
}


def fit_command(path: Path, smoother_wall_s: float, repeats: int) -> dict:
    """Best wall seconds of ``jadhesion fit path --json`` per :data:`FIT_VARIANTS` entry, in this
    process after two warm-up calls (stdout discarded), and the smoother's share of each."""
    out = {}
    for name, extra in FIT_VARIANTS.items():
        argv = ["fit", str(path), "--json", *extra]

        def call(argv=argv):
            with contextlib.redirect_stdout(io.StringIO()):
                code = jadhesion_main(argv)
            if code != 0:
                raise RuntimeError(f"jadhesion {' '.join(argv)} exited {code}")

        for _ in range(2):
            call()
        timing = _best(call, repeats)
        out[name] = {**timing, "smoother_share": smoother_wall_s / timing["wall_s"]}
        print("fit", name, out[name], flush=True)
    return out


def cost(rows_list, work: Path, ref, repeats: int) -> dict:
    """Compiled run times of both smoothers at each size, and LM's at the smallest."""
    out = {}
    for rows in rows_list:
        path = work / f"hour{rows}.csv"
        if not path.exists():
            work.mkdir(parents=True, exist_ok=True)
            _simulate(path, rows)
        recording = load_recording(path)
        args = _signals(recording.columns, recording.vehicle)
        reps = repeats if rows <= 50_000 else max(2, repeats // 10)
        entry = {"rows": int(args[0].shape[0])}
        for name, module in (("reference", ref), ("this", creep_state)):
            entry[name] = _time_smoother(module, args, reps)
            entry[name]["cpu_s_per_row"] = entry[name]["cpu_s"] / entry["rows"]
            print(rows, name, entry[name], flush=True)
        if rows == min(rows_list):
            entry["lm_fit"] = _time_lm(recording, repeats)
            print(rows, "lm", entry["lm_fit"], flush=True)
            for name in ("reference", "this"):
                entry[f"{name}_over_lm"] = {
                    k: entry[name][k] / entry["lm_fit"][k] for k in ("wall_s", "cpu_s")
                }
        out[str(rows)] = entry
    return out


def _irregular(columns, seed=7):
    """The same samples on time stamps with steps drawn uniformly in 0.5–1.5 × the mean step."""
    t = np.asarray(columns["time"])
    steps = np.random.default_rng(seed).uniform(0.5, 1.5, t.size - 1) * np.mean(np.diff(t))
    return {**columns, "time": t[0] + np.concatenate([[0.0], np.cumsum(steps)])}


def _cases(work: Path, largest: int):
    for scenario in ("dry", "wet", "sand"):
        yield f"simulator {scenario} realistic", simulate(scenario, 0).columns
    yield "simulator wet clean", simulate("wet", 1, sensors="clean").columns
    yield "simulator dry realistic x3 noise", simulate("dry", 2, sensor_noise=3.0).columns
    yield "simulator dry irregular time", _irregular(simulate("dry", 3).columns)
    for seed, sensor in ((0, "clean"), (1, "mild"), (2, "realistic"), (3, "realistic"), (4, "realistic")):
        rec = generate(seed, sensor=sensor, duration_s=40.0)
        yield f"foreign seed {seed} {sensor} {rec.truth['rate_hz']:g} Hz", rec.columns
    path = work / f"hour{largest}.csv"
    if path.exists():
        yield f"bench_hours {largest} rows", load_recording(path).columns


def agreement(ref, work: Path, largest: int) -> list:
    """Reference against this tree on each case (module docstring)."""
    rows = []
    for name, columns in _cases(work, largest):
        args = _signals(columns)
        a, b = ref.smooth_creep(*args), creep_state.smooth_creep(*args)
        row = {
            "case": name,
            "rows": int(args[0].shape[0]),
            "q_reference": np.asarray(a.process_q).tolist(),
            "q_this": np.asarray(b.process_q).tolist(),
            "same_q": bool(np.all(np.asarray(a.process_q) == np.asarray(b.process_q))),
            "max_creep_change_over_sd": float(np.max(np.abs(a.creep - b.creep) / a.creep_sd)),
            "max_slip_change_over_sd": float(np.max(np.abs(a.slip - b.slip) / a.slip_sd)),
            "max_rel_change_creep_sd": float(np.max(np.abs(a.creep_sd - b.creep_sd) / a.creep_sd)),
            "max_adhesion_change": float(np.max(np.abs(a.adhesion - b.adhesion))),
        }
        print(row, flush=True)
        rows.append(row)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--reference",
        default="436510c",
        help="git revision of the reference smoother (default: before the fast filter)",
    )
    parser.add_argument("--rows", type=int, nargs="+", default=[2000, 36000, 360000])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--work", type=Path, default=Path("/tmp/jadhesion-bench-hours"))
    parser.add_argument("--skip-agreement", action="store_true")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    this_commit = commit()  # before this run writes its result file (a tracked file)
    ref, ref_commit = reference_module(args.reference)
    doc = {
        "commit": this_commit,
        "reference": {"rev": args.reference, "commit": ref_commit},
        "settings": {
            "rows": args.rows,
            "repeats": args.repeats,
            "recordings": "bench_hours: dry, seed 0, realistic sensors, 100 Hz",
            "lm": "fit_polach(to_dataset(recording), 'lm', key(0)) on the smallest recording",
            "jax": jax.__version__,
            "python": platform.python_version(),
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average_at_start": list(os.getloadavg()),
        },
        "cost": cost(args.rows, args.work, ref, args.repeats),
    }
    # last: the command turns on the persistent compilation cache, which compile times must not see
    small = min(args.rows)
    doc["fit_command"] = fit_command(
        args.work / f"hour{small}.csv", doc["cost"][str(small)]["this"]["wall_s"], args.repeats
    )
    if not args.skip_agreement:
        doc["agreement"] = agreement(ref, args.work, max(args.rows))
    doc["settings"]["load_average_at_end"] = list(os.getloadavg())
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
