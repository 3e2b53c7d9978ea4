"""``peak_below_data``: does ``jadhesion online``'s warning fire on the finals that are far off?

Recordings of the independent generator (:mod:`validation.foreign_generator`, no effect): 4 steady
runs (60 s) and 4 walking-pace starts (30 s), seeds 0–3, at 25, 50, 100 and 200 Hz with mild
sensors, and 4 steady runs, 4 starts and 4 creep sweeps at 50 Hz with realistic sensors. Each is
tracked by Algorithm 1 as ``jadhesion online`` tracks it (forgetting per second, ``a_s`` from the
offline fit). Per run: the final ``mu_max`` against the generator's Polach peak at the median
``|v|`` (:func:`benchmarks.online_recordings.truth_peak`), whether the warning fires
(:func:`jadhesion.identify.online.below_data_warning`) and whether the former level, 0.8 × the
median ``|μ̂|``, would have. Run ``python -m benchmarks.online_peak_below [--out FILE]`` (about 6
minutes); the commit, the settings and the rows go to ``benchmarks/results/online_peak_below.json``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import jax
import numpy as np

from benchmarks.online_recordings import truth_peak
from benchmarks.provenance import commit
from jadhesion.config import enable_x64
from jadhesion.data.recording import load_recording
from jadhesion.data.selected import tracking_dataset
from jadhesion.identify.online import BELOW_DATA_SHARE, below_data_warning, track_dataset
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
MILD = [
    (p, seed, rate) for p in ("steady", "start") for seed in range(4) for rate in (25.0, 50.0, 100.0, 200.0)
]
REALISTIC = [(p, seed, 50.0) for p in ("steady", "start", "sweep") for seed in range(4)]
#: Finals within this of the true peak are "near", beyond it "far" (the table's two columns).
FAR = 0.2


def _row(path: Path, name: str) -> dict:
    rec = load_recording(path)
    data, _ = tracking_dataset(rec)
    time = np.asarray(rec.columns["time"])
    out = track_dataset(data, "1", None, jax.random.key(0), time)
    final = float(out.trace.mu_max[-1])
    peak = truth_peak(path)[0]
    used = np.asarray(out.used, bool)
    warning = below_data_warning(out, data.adhesion, time)
    median = float(np.median(np.abs(np.asarray(data.adhesion))[used]))
    return {
        "recording": name,
        "true_mu_max": peak,
        "final_mu_max": final,
        "final_rel_error": final / peak - 1.0,
        "warned": warning is not None,
        "level": None if warning is None else warning["level"],
        "median_level_warned": bool(final <= BELOW_DATA_SHARE * median),
    }


def _summary(rows: list) -> dict:
    far = [r for r in rows if abs(r["final_rel_error"]) > FAR]
    near = [r for r in rows if abs(r["final_rel_error"]) <= FAR]
    return {
        "finals": len(rows),
        "far": len(far),
        "far_warned": sum(r["warned"] for r in far),
        "far_warned_by_median_level": sum(r["median_level_warned"] for r in far),
        "near": len(near),
        "near_warned": sum(r["warned"] for r in near),
        "far_error_range": [min(r["final_rel_error"] for r in far), max(r["final_rel_error"] for r in far)]
        if far
        else None,
        "near_error_range": [min(r["final_rel_error"] for r in near), max(r["final_rel_error"] for r in near)]
        if near
        else None,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.online_peak_below", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--out", default=str(RESULTS / "online_peak_below.json"))
    args = ap.parse_args(argv)
    enable_x64()
    sha = commit()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for sensor, runs in (("mild", MILD), ("realistic", REALISTIC)):
            for profile, seed, rate in runs:
                kw = {"duration_s": 30.0} if profile == "start" else {}
                rec = generate(seed, effect="none", sensor=sensor, rate_hz=rate, profile=profile, **kw)
                name = f"{profile}/{seed}/{rate:g}Hz/{sensor}"
                rows.append(_row(write(rec, Path(tmp) / f"{profile}_{seed}_{rate:g}_{sensor}.csv"), name))
                r = rows[-1]
                print(f"{name:28s} final {r['final_rel_error']:+.2f} warned {r['warned']}", flush=True)
    doc = {
        "commit": sha,
        "settings": {
            "mild": MILD,
            "realistic": REALISTIC,
            "algorithm": "1",
            "forgetting": "seconds",
            "far": FAR,
        },
        "summary": _summary(rows),
        "rows": rows,
    }
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc["summary"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
