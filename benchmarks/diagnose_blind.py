"""Blind benchmark of ``jadhesion diagnose``: simulated recordings with 0, 1 or 2 concealed effects,
plus a null set of clean recordings for the false-alarm rate.

Each case: random scenario (dry/wet/sand), seed (profile wander, excursions, noise), vehicle (the
22E or a variant: worn radius 0.57–0.61 m, inertia ±25 %, axle load 18–23 t), driving profile (the
published test or, with probability ``--p-varied``, a different one: speed, ramp, creep level,
wander, excursions, Polach parameters ×0.8–1.2, 1500–3000 samples) and effects with log-uniform
magnitudes over the effect registry's ``typical`` ranges (reaching well below the detection
thresholds). The diagnoser sees only the CSV and a vehicle-only sidecar, through the CLI's code
path. Reported: confusion matrix (true primary effect × verdict), false alarms on clean recordings
(k/n with a 95 % Clopper–Pearson interval), per effect top-1 accuracy in magnitude bins and above
its documented detection threshold (the registry's ``detection.top1``:
:data:`jadhesion.models.effects.DETECTION_PROVENANCE`), "truth in the reported set" (verdict or its
indistinguishable set), the measured 90 % threshold, relative error of the recovered magnitude and
how often its 90 % interval (``extended.uncertainty``) holds the truth where the effect was named,
base-fit parameter errors, seconds per diagnosis, and top-1 accuracy above and below each
recording's own predicted ``min_detectable`` magnitude (:mod:`jadhesion.diagnose.sensitivity`), and
the coverage of the rail change's time interval (``extended.change_time``,
:mod:`jadhesion.diagnose.change_time`) where a true change was named.

    python -m benchmarks.diagnose_blind [--n 220] [--null 80] [--seed 0] [--coast S] [--json]
    python -m benchmarks.diagnose_blind --from-cases benchmarks/results/diagnose_blind_cases.json
    python -m benchmarks.diagnose_blind --upper 0.5:1.5 --n 56 --null 0   # the top of each range

``--upper F:G`` asks whether a threshold lies at the top of an effect's range: single effects,
each in turn, |magnitude| log-uniform on [F, G] × the top of its typical range (the diagnosis
ranks sizes up to 1.5 × that top, :meth:`jadhesion.models.effect_spec.EffectSpec.plausible`).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.provenance import commit
from jadhesion.cli.common import Progress, emit_json, table
from jadhesion.config import enable_compilation_cache, enable_x64
from jadhesion.diagnose.extensions import NAMES
from jadhesion.diagnose.select import GAIN_THRESHOLD, effects_from
from jadhesion.models.effects import DETECTION_PROVENANCE, EFFECTS
from jadhesion.models.polach import PARAM_NAMES
from validation.diagnose_cases import random_effects, run_case

RESULTS = Path(__file__).resolve().parent / "results"
#: A measured detection threshold: the smallest |magnitude| above which at least MIN_CASES cases
#: are named with top-1 accuracy ≥ TARGET_ACCURACY.
TARGET_ACCURACY = 0.9
MIN_CASES = 5
#: Mix of the main cases: clean, one effect, two effects.
P_CLEAN, P_PAIR = 0.15, 0.1


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
        d["effects"], close = effects_from(d["candidates"], d["second_round"], threshold)
        d["verdict"] = d["effects"][0] if d["effects"] else "none"
        d["indistinguishable"] = [{"name": n} for n in close]


#: What a candidate row needs for :func:`~jadhesion.diagnose.select.effects_from` to re-take a
#: decision offline (with the held-out error and the fitted parameters for other rankings).
DECISION_KEYS = ("name", "gain", "delta_bic", "sse_reduction", "p_value", "status", "plausible", "params")


def decision_table(d: dict) -> dict:
    """The effects found and the candidate tables of a diagnosis (both rounds, with round 2's
    refit of the first effect) with :data:`DECISION_KEYS` only: enough to re-decide it under
    another rule without refitting."""

    def rows(cands):
        return [{k: c.get(k) for k in DECISION_KEYS} for c in cands]

    second = d.get("second_round")
    if second:
        second = {
            "first": second["first"],
            "first_refit": second.get("first_refit"),
            "candidates": rows(second["candidates"]),
        }
    return {"effects": d["effects"], "candidates": rows(d["candidates"]), "second_round": second}


def clopper_pearson(k: int, n: int, level: float = 0.95) -> list:
    """Exact binomial interval for k successes in n trials."""
    from scipy.stats import beta

    a = 1.0 - level
    lo = float(beta.ppf(a / 2, k, n - k + 1)) if k > 0 else 0.0
    hi = float(beta.ppf(1 - a / 2, k + 1, n - k)) if k < n else 1.0
    return [lo, hi]


def rate(hits) -> dict:
    k, n = int(sum(hits)), len(hits)
    return {"k": k, "n": n, "rate": k / n if n else None, "ci95": clopper_pearson(k, n) if n else None}


def change_time_coverage(found) -> dict:
    """Of the true rail changes ``found``, ``(extended.change_time or None, true time [s])`` pairs:
    how many the extended model holds (``named``), how many of those intervals hold the true time
    (``covered``, k/n with its 95 % interval; nominal 90 %), with the fit's time inside
    (``fit_inside``) and the intervals' median width [s]."""
    named = [(ct, t) for ct, t in found if ct]
    inside = [ct["t_change_interval_s"][0] <= t <= ct["t_change_interval_s"][1] for ct, t in named]
    widths = [ct["t_change_interval_s"][1] - ct["t_change_interval_s"][0] for ct, _ in named]
    return {
        "true_changes": len(found),
        "named": len(named),
        "covered": rate(inside),
        "fit_inside": rate([ct["fit_inside"] for ct, _ in named]),
        "median_width_s": float(np.median(widths)) if widths else None,
        "level": named[0][0]["level"] if named else None,
    }


def reported_set(d) -> set:
    """The verdict's effects and the effects reported as indistinguishable from it."""
    return set(d["effects"]) | {c["name"] for c in d.get("indistinguishable", [])}


def measured_threshold(mags, hits, target=TARGET_ACCURACY, min_cases=MIN_CASES):
    """Smallest |magnitude| m such that the cases with |magnitude| ≥ m (at least ``min_cases``)
    are named correctly in ≥ ``target`` of cases; None if no such m."""
    order = np.argsort(mags)[::-1]
    m, h = np.asarray(mags)[order], np.asarray(hits, float)[order]
    acc = np.cumsum(h) / np.arange(1, len(h) + 1)
    ok = [i for i in range(len(h)) if i + 1 >= min_cases and acc[i] >= target]
    return float(m[max(ok)]) if ok else None


def above_own_limit(diagnosis: dict, name: str, magnitude: float):
    """Whether ``|magnitude|`` (our units) reaches the recording's own ``min_detectable`` of the
    effect (:mod:`jadhesion.diagnose.sensitivity`); None where the diagnosis gives no limit."""
    limit = diagnosis.get("sensitivity", {}).get(name, {}).get("min_detectable")
    return None if limit is None else bool(abs(magnitude) >= limit)


def own_limit_rates(hits, own) -> dict:
    """``top1_above_min_detectable`` and ``top1_below_min_detectable``: :func:`rate` of ``hits``
    among the cases whose size reaches their recording's own limit (``own`` True, from
    :func:`above_own_limit`) and among those below it (False; None counts in neither)."""
    pairs = list(zip(hits, own, strict=True))
    return {
        "top1_above_min_detectable": rate([h for h, v in pairs if v]),
        "top1_below_min_detectable": rate([h for h, v in pairs if v is False]),
    }


def summarise(cases) -> dict:
    main = [c for c in cases if c.get("set", "main") == "main"]
    labels = ["none", *NAMES]
    confusion = {t: {p: 0 for p in labels} for t in labels}
    for c in main:
        truth = c["effects"][0][0] if c["effects"] else "none"
        confusion[truth][c["diagnosis"]["verdict"]] += 1
    clean = [c for c in cases if not c["effects"]]
    alarms = {
        "all_clean": rate([c["diagnosis"]["verdict"] != "none" for c in clean]),
        "null_set": rate([c["diagnosis"]["verdict"] != "none" for c in clean if c.get("set") == "null"]),
        "varied_vehicle_or_profile": rate(
            [
                c["diagnosis"]["verdict"] != "none"
                for c in clean
                if c["vehicle_varied"] or c.get("profile_varied")
            ]
        ),
        "generic_term_used": rate([c["diagnosis"]["generic"]["used"] for c in clean]),
    }
    per_effect = {}
    for name in NAMES:
        single = [c for c in main if len(c["effects"]) == 1 and c["effects"][0][0] == name]
        mags = [abs(c["effects"][0][1]) for c in single]
        hits = [c["diagnosis"]["verdict"] == name for c in single]
        in_set = [name in reported_set(c["diagnosis"]) for c in single]
        lo, hi = EFFECTS[name].typical
        edges = np.exp(np.linspace(np.log(lo), np.log(hi), 4))
        bins = []
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            sel = [i for i, m in enumerate(mags) if a <= m <= b]
            bins.append(
                {
                    "range": [float(a), float(b)],
                    "n": len(sel),
                    "top1": float(np.mean([hits[i] for i in sel])) if sel else None,
                    "in_set": float(np.mean([in_set[i] for i in sel])) if sel else None,
                }
            )
        documented = EFFECTS[name].detection.top1
        above = [i for i, m in enumerate(mags) if documented is not None and m >= documented]
        errors, covered = [], []
        for c in single:
            if c["diagnosis"]["verdict"] == name:
                param = EFFECTS[name].magnitude_param
                cand = next(x for x in c["diagnosis"]["candidates"] if x["name"] == name)
                est, true = cand["params"][param], c["effects"][0][1]
                errors.append(abs(est - true) / abs(true))
                ci = c["diagnosis"]["extended"].get("uncertainty", {}).get("ci90", {}).get(param)
                covered.append(ci is not None and ci[0] <= true <= ci[1])
        # The recording's own prediction (diagnosis["sensitivity"]): is |m| above what it can see?
        own = [above_own_limit(c["diagnosis"], name, m) for c, m in zip(single, mags, strict=True)]
        default = [i for i, c in enumerate(single) if not c.get("profile_varied")]
        varied = [i for i, c in enumerate(single) if c.get("profile_varied")]
        per_effect[name] = {
            "n": len(single),
            "bins": bins,
            "top1": rate(hits),
            "in_set": rate(in_set),
            "top1_default_profile": rate([hits[i] for i in default]),
            "top1_varied_profile": rate([hits[i] for i in varied]),
            "measured_threshold": measured_threshold(mags, hits),
            "measured_threshold_in_set": measured_threshold(mags, in_set),
            "documented_threshold": documented,
            "top1_above_documented": rate([hits[i] for i in above]),
            "in_set_above_documented": rate([in_set[i] for i in above]),
            **own_limit_rates(hits, own),
            "confused_with": {k: v for k, v in confusion[name].items() if v and k != name},
            "median_rel_error": float(np.median(errors)) if errors else None,
            "ci90_covers_magnitude": rate(covered),
            "cases": [[m, bool(h), bool(s)] for m, h, s in zip(mags, hits, in_set, strict=True)],
        }
    pairs = [c for c in main if len(c["effects"]) == 2]
    truth_sets = [{e[0] for e in c["effects"]} for c in pairs]
    base_err = {k: [] for k in PARAM_NAMES}
    for c in clean:
        if "true_params" in c:
            for k in PARAM_NAMES:
                base_err[k].append(abs(c["diagnosis"]["base"]["params"][k] - c["true_params"][k]))
    single_all = [c for c in main if len(c["effects"]) == 1]
    named = [c["diagnosis"]["verdict"] == c["effects"][0][0] for c in single_all]
    own = [above_own_limit(c["diagnosis"], *c["effects"][0]) for c in single_all]
    seconds = [c["diagnosis"]["seconds"] for c in cases]
    return {
        "n": len(cases),
        "n_main": len(main),
        "n_clean": len(clean),
        "confusion": confusion,
        "false_alarms": alarms,
        "false_alarm_rate": alarms["all_clean"]["rate"],
        "per_effect": per_effect,
        "single_effect": {
            "top1": rate([c["diagnosis"]["verdict"] == c["effects"][0][0] for c in single_all]),
            "in_set": rate([c["effects"][0][0] in reported_set(c["diagnosis"]) for c in single_all]),
            "missed": rate([c["diagnosis"]["verdict"] == "none" for c in single_all]),
            **own_limit_rates(named, own),
        },
        "pairs": {
            "n": len(pairs),
            "both_named": rate(
                [set(c["diagnosis"]["effects"]) == t for c, t in zip(pairs, truth_sets, strict=True)]
            ),
            "one_named": rate(
                [bool(set(c["diagnosis"]["effects"]) & t) for c, t in zip(pairs, truth_sets, strict=True)]
            ),
        },
        "base_params_clean_median_abs_error": {
            k: float(np.median(v)) if v else None for k, v in base_err.items()
        },
        "change_time": change_time_coverage(
            [
                (c["diagnosis"]["extended"].get("change_time"), c["truth"]["rail_change"]["time_s"])
                for c in main
                if "rail_change" in c["truth"]
            ]
        ),
        "seconds_per_diagnosis": {
            "median": float(np.median(seconds)),
            "p90": float(np.quantile(seconds, 0.9)),
            "max": float(np.max(seconds)),
        },
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=220, help="main recordings (default 220)")
    parser.add_argument("--null", type=int, default=80, help="extra clean recordings (default 80)")
    parser.add_argument(
        "--p-varied", type=float, default=0.3, help="probability of a varied driving profile (default 0.3)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--samples", type=int, default=None, help="samples per default recording")
    parser.add_argument(
        "--coast",
        type=float,
        default=0.0,
        metavar="S",
        help="a coasting gap of S seconds in every recording (default 0: none)",
    )
    parser.add_argument(
        "--upper",
        default=None,
        metavar="F:G",
        help="single effects in turn, |magnitude| in [F, G] x the top of the typical range",
    )
    parser.add_argument("--json", action="store_true", help="one JSON document on stdout")
    parser.add_argument(
        "--out",
        default=str(RESULTS / "diagnose_blind.json"),
        help="summary JSON (default benchmarks/results/diagnose_blind.json)",
    )
    parser.add_argument(
        "--cases",
        metavar="FILE",
        default=str(RESULTS / "diagnose_blind_cases.json"),
        help="all cases, rewritten after every case (summarise early with --from-cases)",
    )
    parser.add_argument(
        "--from-cases",
        metavar="FILE",
        default=None,
        help="summarise stored cases (re-deciding at the current threshold)",
    )
    args = parser.parse_args(argv)
    if args.from_cases:
        with open(args.from_cases) as fh:
            cases = json.load(fh)
        redecide(cases)
        summary = summarise(cases)
        summary["commit"] = commit()  # the summarising code; the cases carry no commit of their own
        summary["settings"] = {
            "from_cases": args.from_cases,
            "gain_threshold": GAIN_THRESHOLD,
            "documented_thresholds": DETECTION_PROVENANCE,
        }
        return report(summary, args.json, args.out)
    enable_x64()
    enable_compilation_cache()
    head = commit()
    rng = np.random.default_rng(args.seed)
    total = args.n + args.null
    upper = None if args.upper is None else _span(parser, args.upper)
    progress = Progress(total, "diagnoses", enabled=not args.json or sys.stderr.isatty())
    cases = []
    Path(args.cases).parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(total):  # null cases spread evenly, so a cut-short run has both kinds
            is_main = (i + 1) * args.null // total == i * args.null // total
            if not is_main:
                effects = []
            elif upper is None:
                effects = draw(rng)
            else:
                effects = random_effects(rng, [NAMES[len(cases) % len(NAMES)]], upper)
            case = run_case(
                effects,
                rng,
                tmp,
                args.samples,
                p_varied_profile=args.p_varied,
                coast_s=args.coast,
            )
            case["set"] = "main" if is_main else "null"
            cases.append(case)
            progress.update()
            with open(args.cases, "w") as fh:
                json.dump(cases, fh, default=float)
    summary = summarise(cases)
    summary["commit"] = head
    summary["settings"] = {
        "n": args.n,
        "null": args.null,
        "p_varied": args.p_varied,
        "seed": args.seed,
        "samples": args.samples,
        "coast_s": args.coast,
        "upper": upper,
        "gain_threshold": GAIN_THRESHOLD,
        "replicas": 19,
        "phase": "traction",
        "sensors": "realistic",
        "documented_thresholds": DETECTION_PROVENANCE,
    }
    return report(summary, args.json, args.out)


def _span(parser, text: str) -> tuple:
    """``--upper F:G`` as ``(F, G)``, 0 < F < G (else the parser's error: exit 2)."""
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        parser.error(f"--upper: F:G expected, got {text!r}")
    if not 0.0 < lo < hi:
        parser.error(f"--upper: 0 < F < G required, got {text!r}")
    return lo, hi


def report(summary, as_json: bool, out) -> int:
    if out:
        with open(out, "w") as fh:
            json.dump(summary, fh, indent=1, default=float)
    if as_json:
        emit_json(summary)
        return 0
    labels = ["none", *NAMES]
    rows = [{"truth": t, **{p[:8]: summary["confusion"][t][p] for p in labels}} for t in labels]
    print(table(rows, ["truth", *[p[:8] for p in labels]]))
    for key, r in summary["false_alarms"].items():
        if r["n"]:
            print(
                f"false alarms, {key}: {r['k']}/{r['n']} = {r['rate']:.1%} "
                f"(95 % CI {r['ci95'][0]:.1%}–{r['ci95'][1]:.1%})"
            )
    for name, s in summary["per_effect"].items():
        bins = ", ".join(
            f"[{b['range'][0]:.3g}, {b['range'][1]:.3g}]: "
            + (f"{b['top1']:.0%}/{b['in_set']:.0%} of {b['n']}" if b["n"] else "-")
            for b in s["bins"]
        )
        err = s["median_rel_error"]
        above = s["top1_above_documented"]
        print(
            f"{name:20s} top-1/in-set by |magnitude|: {bins}; measured 90 % threshold "
            f"{s['measured_threshold']} (in set {s['measured_threshold_in_set']}); above the "
            f"documented {s['documented_threshold']}: "
            + (f"{above['k']}/{above['n']}" if above["n"] else "-")
            + "; above / below the recording's min_detectable: "
            + " / ".join(
                f"{r['k']}/{r['n']}" if r["n"] else "-"
                for r in (s["top1_above_min_detectable"], s["top1_below_min_detectable"])
            )
            + f"; median rel. error {'-' if err is None else f'{err:.3f}'}"
            + f"; 90 % interval holds it {s['ci90_covers_magnitude']['k']}/{s['ci90_covers_magnitude']['n']}"
        )
    print(f"single effects: {summary['single_effect']}")
    print(f"pairs: {summary['pairs']}")
    print(f"base params on clean recordings, median |error|: {summary['base_params_clean_median_abs_error']}")
    print(f"rail change time intervals: {summary['change_time']}")
    print(f"seconds per diagnosis: {summary['seconds_per_diagnosis']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
