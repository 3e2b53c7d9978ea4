"""Blind benchmark of ``jadhesion diagnose``: simulated recordings with 0, 1 or 2 concealed effects.

Each case: random scenario (dry/wet/sand), seed (profile wander, excursions, noise), vehicle (the
22E or a variant with a worn radius 0.57–0.61 m and inertia ±25 %), and effects with log-uniform
magnitudes over :data:`jadhesion.diagnose.calibrate.MAGNITUDE_RANGE` (reaching well below the
detection thresholds). The diagnoser sees only the CSV and a vehicle-only sidecar, through the CLI's
code path. Reported: confusion matrix (true primary effect × verdict), false-alarm rate on clean
recordings, top-1 accuracy per effect in magnitude bins, relative error of recovered magnitudes,
seconds per diagnosis.

    python benchmarks/diagnose_blind.py [--n 200] [--json] [--seed 0] [--samples N]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile

import numpy as np

from jadhesion.cli.common import Progress, emit_json, table
from jadhesion.config import enable_compilation_cache, enable_x64
from jadhesion.diagnose.calibrate import MAGNITUDE_RANGE, random_effects, run_case
from jadhesion.diagnose.extensions import NAMES
from jadhesion.diagnose.select import GAIN_THRESHOLD, effects_from

#: Mix of cases: clean, one effect, two effects.
P_CLEAN, P_PAIR = 0.25, 0.1
#: The parameter of the extended model that estimates each effect's magnitude.
MAGNITUDE_PARAM = {"rail_change": "drop", "wheel_radius_error": "delta_r",
                   "signal_delay": "delay_s", "speed_dependence": "slope",
                   "torque_offset": "offset", "thermal_softening": "softening",
                   "load_transfer": "load_m"}


def draw(rng) -> list:
    u = rng.random()
    if u < P_CLEAN:
        return []
    k = 2 if u > 1.0 - P_PAIR else 1
    return random_effects(rng, list(rng.choice(NAMES, size=k, replace=False)))


def redecide(cases, threshold=GAIN_THRESHOLD) -> None:
    """Re-take each decision at ``threshold`` from the stored candidate gains (exact: round 2 is
    always fitted above :data:`~jadhesion.diagnose.select.ROUND2_MIN`)."""
    for c in cases:
        d = c["diagnosis"]
        d["effects"], _ = effects_from(d["candidates"], d["second_round"], threshold)
        d["verdict"] = d["effects"][0] if d["effects"] else "none"


def summarise(cases) -> dict:
    labels = ["none", *NAMES]
    confusion = {t: {p: 0 for p in labels} for t in labels}
    for c in cases:
        truth = c["effects"][0][0] if c["effects"] else "none"
        confusion[truth][c["diagnosis"]["verdict"]] += 1
    clean = [c for c in cases if not c["effects"]]
    false_alarm = (sum(c["diagnosis"]["verdict"] != "none" for c in clean) / len(clean)
                   if clean else float("nan"))
    per_effect = {}
    for name in NAMES:
        single = [c for c in cases if len(c["effects"]) == 1 and c["effects"][0][0] == name]
        lo, hi = MAGNITUDE_RANGE[name]
        edges = np.exp(np.linspace(np.log(lo), np.log(hi), 4))
        bins = []
        for a, b in zip(edges[:-1], edges[1:]):
            sel = [c for c in single if a <= abs(c["effects"][0][1]) <= b]
            hits = [c["diagnosis"]["verdict"] == name for c in sel]
            bins.append({"range": [float(a), float(b)], "n": len(sel),
                         "top1": float(np.mean(hits)) if hits else None})
        errors = []
        for c in single:
            if c["diagnosis"]["verdict"] == name:
                cand = next(x for x in c["diagnosis"]["candidates"] if x["name"] == name)
                est = cand["params"][MAGNITUDE_PARAM[name]]
                true = c["effects"][0][1]
                errors.append(abs(est - true) / abs(true))
        per_effect[name] = {"n": len(single), "bins": bins,
                            "top1": float(np.mean([c["diagnosis"]["verdict"] == name
                                                   for c in single])) if single else None,
                            "median_rel_error": float(np.median(errors)) if errors else None}
    pairs = [c for c in cases if len(c["effects"]) == 2]
    pair_hits = [set(c["diagnosis"]["effects"]) == {e[0] for e in c["effects"]} for c in pairs]
    pair_any = [bool(set(c["diagnosis"]["effects"]) & {e[0] for e in c["effects"]}) for c in pairs]
    varied = [c for c in cases if c["vehicle_varied"] and not c["effects"]]
    return {
        "n": len(cases), "confusion": confusion, "false_alarm_rate": false_alarm,
        "n_clean": len(clean),
        "false_alarm_rate_varied_vehicle": (float(np.mean([c["diagnosis"]["verdict"] != "none"
                                                            for c in varied])) if varied else None),
        "per_effect": per_effect,
        "pairs": {"n": len(pairs), "both_named": float(np.mean(pair_hits)) if pairs else None,
                  "one_named": float(np.mean(pair_any)) if pairs else None},
        "seconds_per_diagnosis": float(np.median([c["diagnosis"]["seconds"] for c in cases])),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="number of recordings (default 200)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--samples", type=int, default=None, help="samples per recording")
    parser.add_argument("--json", action="store_true", help="one JSON document on stdout")
    parser.add_argument("--cases", metavar="FILE", default=None, help="also write all cases")
    parser.add_argument("--from-cases", metavar="FILE", default=None,
                        help="summarise stored cases (re-deciding at the current threshold)")
    args = parser.parse_args(argv)
    if args.from_cases:
        with open(args.from_cases) as fh:
            cases = json.load(fh)
        redecide(cases)
        return report(summarise(cases), args.json)
    enable_x64()
    enable_compilation_cache()
    rng = np.random.default_rng(args.seed)
    progress = Progress(args.n, "diagnoses", enabled=not args.json or sys.stderr.isatty())
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.n):
            cases.append(run_case(draw(rng), rng, tmp, args.samples))
            progress.update()
            if args.cases:  # rewritten after every case: a long run can be summarised early
                with open(args.cases, "w") as fh:
                    json.dump(cases, fh, default=float)
    return report(summarise(cases), args.json)


def report(summary, as_json: bool) -> int:
    if as_json:
        emit_json(summary)
        return 0
    labels = ["none", *NAMES]
    rows = [{"truth": t, **{p[:8]: summary["confusion"][t][p] for p in labels}} for t in labels]
    print(table(rows, ["truth", *[p[:8] for p in labels]]))
    print(f"false alarms on clean recordings: {summary['false_alarm_rate']:.1%} "
          f"({summary['n_clean']} clean)")
    for name, s in summary["per_effect"].items():
        bins = ", ".join(f"[{b['range'][0]:.3g}, {b['range'][1]:.3g}]: "
                         + (f"{b['top1']:.0%} of {b['n']}" if b["n"] else "-") for b in s["bins"])
        err = s["median_rel_error"]
        print(f"{name:20s} top-1 by |magnitude|: {bins}; median rel. error "
              f"{'-' if err is None else f'{err:.3f}'}")
    print(f"pairs: {summary['pairs']}")
    print(f"median seconds per diagnosis: "
          f"{summary['seconds_per_diagnosis']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
