"""False alarms of ``jadhesion diagnose`` on clean recordings of three generators, with the
per-recording null (:mod:`jadhesion.diagnose.null`).

``ours``: :func:`validation.diagnose_cases.run_case` without effects (random scenario, seed,
vehicle, driving profile; the simulator's default ``sensors="realistic"``; ``--coast S`` gives every
recording an S-second coasting gap, :attr:`jadhesion.data.scenarios.Scenario.coast_s`). ``foreign``:
:func:`validation.foreign_generator.generate` with ``effect="none"`` (its own vehicles, profiles,
sampling rates 20–200 Hz and realistic sensor model). ``kinematic``:
:func:`validation.kinematic_generator.generate`, its four profiles in turn (mainline, braking —
diagnosed with ``--phase braking`` —, walking pace, constant-speed sweeps), each with random
Polach parameters, vehicle, logger rate (20–200 Hz) and white speed noise (0.002–0.02 m/s,
log-uniform), written as its logger file. Every recording goes through a file and the CLI's code
path. Reported per generator: false alarms k/n with a 95 % Clopper–Pearson interval, the verdicts,
the smallest p-value per recording, the generic discrepancy's held-out gain (and how many passed
its threshold), the warnings, seconds per diagnosis; the result file records the commit, the
settings and the load average (2 shared cores: timings are noisy).

    python -m benchmarks.diagnose_null [--n 10] [--seed 0] [--duration 30] [--coast S]
        [--generators ours,foreign,kinematic] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.diagnose_blind import clopper_pearson, commit, decision_table
from jadhesion.cli.diagnose_run import diagnose_file
from jadhesion.config import enable_compilation_cache, enable_x64
from validation import kinematic_generator
from validation.diagnose_cases import run_case
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"


def summary_of(d: dict) -> dict:
    """The parts of a diagnosis a false-alarm count needs."""
    ps = [c["p_value"] for c in d["candidates"] if c["p_value"] is not None]
    return {
        "verdict": d["verdict"],
        "effects": d["effects"],
        "min_p": min(ps) if ps else None,
        "top": [
            {k: c[k] for k in ("name", "gain", "sse_reduction", "p_value", "status")}
            for c in d["candidates"][:3]
        ],
        "critical_sse_reduction": d["null"]["critical_sse_reduction"],
        "base_status": d["base"]["status"],
        "base_mu0": d["base"]["params"]["mu0"],
        "generic_gain": d["generic"]["gain"],
        "generic_used": d["generic"]["used"],
        "warnings": [w["code"] for w in d["warnings"]],
        "used": d.get("selection", {}).get("used"),
        "seconds": d["seconds"],
        "null_error": d["null"]["noise"]["error"] if d["null"]["noise"] else None,
        "decision": decision_table(d),
    }


def foreign_case(seed: int, directory, duration: float) -> dict:
    rec = generate(seed, effect="none", duration_s=duration)
    path = write(rec, Path(directory) / f"foreign_{seed}.csv", truth=False)
    start = time.perf_counter()
    result, _ = diagnose_file(path)
    result["seconds"] = time.perf_counter() - start
    return {
        "seed": seed,
        "rate_hz": rec.truth["rate_hz"],
        "profile": rec.truth["profile"]["kind"],
        "vehicle": rec.truth["vehicle"].get("name"),
        "n_samples": rec.truth["n_samples"],
        **summary_of(result),
    }


def kinematic_case(seed: int, directory, duration: float) -> dict:
    rng = np.random.default_rng(seed)
    kind = kinematic_generator.KINDS[seed % len(kinematic_generator.KINDS)]
    settings = kinematic_generator.random_settings(rng)
    rec = kinematic_generator.generate(seed, kind, duration_s=duration, **settings)
    path = kinematic_generator.write(rec, Path(directory) / f"kinematic_{seed}.csv")
    phase = kinematic_generator.phase(kind)
    start = time.perf_counter()
    result, _ = diagnose_file(path, phase=phase)
    result["seconds"] = time.perf_counter() - start
    return {"seed": seed, "kind": kind, "phase": phase, **settings, **summary_of(result)}


def ours_case(rng, directory, coast_s: float = 0.0) -> dict:
    case = run_case([], rng, directory, p_varied_profile=0.3, coast_s=coast_s)
    return {
        "scenario": case["scenario"],
        "seed": case["seed"],
        "vehicle_varied": case["vehicle_varied"],
        "profile_varied": case["profile_varied"],
        "n_samples": case["n_samples"],
        **summary_of(case["diagnosis"]),
    }


def rate(cases) -> dict:
    k, n = sum(c["verdict"] != "none" for c in cases), len(cases)
    return {"k": k, "n": n, "rate": k / n if n else None, "ci95": clopper_pearson(k, n) if n else None}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10, help="clean recordings per generator (default 10)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--duration", type=float, default=30.0, help="foreign and kinematic recordings' length [s]"
    )
    parser.add_argument("--generators", default="ours,foreign", help="ours, foreign, kinematic")
    parser.add_argument(
        "--coast",
        type=float,
        default=0.0,
        metavar="S",
        help="ours: a coasting gap of S seconds in every recording (default 0: none; theirs never do)",
    )
    parser.add_argument("--out", default=str(RESULTS / "diagnose_null.json"))
    args = parser.parse_args(argv)
    enable_x64()
    enable_compilation_cache()
    rng = np.random.default_rng(args.seed)
    gens = args.generators.split(",")
    cases = {g: [] for g in gens}
    doc, head = {}, commit()  # the code this process imported
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.n):  # interleaved, so a cut-short run has both generators
            for g in gens:
                if g == "ours":
                    case = ours_case(rng, tmp, args.coast)
                elif g == "kinematic":
                    case = kinematic_case(args.seed * 1000 + i, tmp, args.duration)
                else:
                    case = foreign_case(args.seed * 1000 + i, tmp, args.duration)
                cases[g].append(case)
                print(f"{g} {i}: {case['verdict']} min p {case['min_p']} {case['seconds']:.1f} s", flush=True)
                doc = {
                    "commit": head,
                    "settings": {
                        **vars(args),
                        "replicas": 19,
                        "phase": "traction",
                        "ours_sensors": "realistic",
                    },
                    "loadavg_end": os.getloadavg(),
                    "false_alarms": {g: rate(c) for g, c in cases.items()},
                    "generic_used": {g: sum(x["generic_used"] for x in c) for g, c in cases.items()},
                    "seconds_median": {
                        g: float(np.median([x["seconds"] for x in c])) if c else None
                        for g, c in cases.items()
                    },
                    "cases": cases,
                }
                Path(args.out).write_text(json.dumps(doc, indent=1, default=float))
    for g, r in doc["false_alarms"].items():
        print(f"{g}: false alarms {r['k']}/{r['n']} (95 % CI {r['ci95'][0]:.1%}–{r['ci95'][1]:.1%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
