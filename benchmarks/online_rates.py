"""``jadhesion online`` against the logging rate: forgetting per sample (the paper's) or per second.

The paper's forgetting factor η is per sample, so at a higher logging rate the estimate remembers
fewer seconds. Recordings: the independent generator's (:mod:`validation.foreign_generator`, no
effect, mild sensors) 4 steady runs (60 s) and 4 walking-pace starts (30 s), seeds 0–3, each
generated at 25, 50, 100, 200 and 500 Hz. Each is tracked as ``jadhesion online`` tracks it
(:func:`jadhesion.data.selected.tracking_dataset`, ``a_s`` from the offline fit) by Algorithms 1, 2
and RLS with ``--forgetting samples`` and ``seconds``. Per run: the median relative error of the
tracked ``mu_max`` over the second half against the generator's Polach peak at the median ``|v|``
(as :mod:`benchmarks.online_recordings`), and the final one. Run ``python -m benchmarks.online_rates
[--out FILE]`` (about 3 minutes); the commit, the settings and the rows go to
``benchmarks/results/online_rates.json``.
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
from jadhesion.identify.online import FORGETTING, track_dataset
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
RUNS = [("steady", seed) for seed in range(4)] + [("start", seed) for seed in range(4)]
RATES_HZ = (25.0, 50.0, 100.0, 200.0, 500.0)
ALGORITHMS = ("1", "2", "rls")


def _row(path: Path, rate: float, profile: str, seed: int) -> dict:
    rec = load_recording(path)
    peak = truth_peak(path)[0]
    data, _ = tracking_dataset(rec)
    time = np.asarray(rec.columns["time"])
    late = time > 0.5 * time[-1]
    row = {"profile": profile, "seed": seed, "rate_hz": rate, "true_mu_max": peak, "errors": {}}
    for algorithm in ALGORITHMS:
        for forgetting in FORGETTING:
            per_second = time if forgetting == "seconds" else None
            out = track_dataset(data, algorithm, None, jax.random.key(0), per_second)
            mu_max = np.asarray(out.trace.mu_max)
            row["errors"][f"{algorithm}/{forgetting}"] = {
                "median_late": float(np.median(np.abs(mu_max[late] / peak - 1.0))),
                "final": float(mu_max[-1] / peak - 1.0),
            }
    return row


def _summary(rows: list) -> dict:
    out = {}
    for key in rows[0]["errors"]:
        out[key] = {}
        for rate in RATES_HZ:
            errors = [r["errors"][key]["median_late"] for r in rows if r["rate_hz"] == rate]
            out[key][f"{rate:g}"] = {"median": float(np.median(errors)), "max": float(np.max(errors))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.online_rates", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--out", default=str(RESULTS / "online_rates.json"))
    args = ap.parse_args(argv)
    enable_x64()
    sha = commit()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for profile, seed in RUNS:
            kw = {"profile": "start", "duration_s": 30.0} if profile == "start" else {"profile": "steady"}
            for rate in RATES_HZ:
                rec = generate(seed, effect="none", sensor="mild", rate_hz=rate, **kw)
                path = write(rec, Path(tmp) / f"{profile}_{seed}_{rate:g}.csv")
                rows.append(_row(path, rate, profile, seed))
                errs = " ".join(f"{k} {v['median_late']:.3f}" for k, v in rows[-1]["errors"].items())
                print(f"{profile} {seed} {rate:5g} Hz  {errs}", flush=True)
    doc = {
        "commit": sha,
        "settings": {
            "runs": RUNS,
            "rates_hz": list(RATES_HZ),
            "sensor": "mild",
            "algorithms": list(ALGORITHMS),
            "forgetting": list(FORGETTING),
            "error": "median |mu_max / true peak - 1| over the second half of each run",
        },
        "summary": _summary(rows),
        "rows": rows,
    }
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc["summary"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
