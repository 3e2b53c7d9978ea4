"""Blind diagnosis of concealed effects in recordings of the foreign generator
(:mod:`validation.foreign_generator`: its own physics, vehicles, driving profiles, sampling rates
and realistic sensor noise), through the CLI's code path.

Each effect of the catalogue is concealed in ``--per-effect`` recordings at magnitudes drawn from
the foreign generator's own typical range (its units: ``rail_change`` is ``μ0 → μ0(1 + m)``, so our
``drop`` ≈ −m; ``speed_dependence``, ``thermal_softening`` and ``load_transfer`` follow other laws
than our extensions, so their magnitudes are not compared). Reported: the confusion matrix (truth ×
verdict), top-1 and "truth in the verdict's indistinguishable set" per effect, the recovered
magnitude beside the true one where the units agree (and whether its 90 % interval,
``extended.uncertainty``, holds it), top-1 where the size reaches the recording's own
``sensitivity.min_detectable`` and where it does not (the effects in our units), the coverage of the
rail change's time interval (``extended.change_time``) where a change was named, and seconds per
diagnosis; the result file records the commit, the settings and the load average (2 shared cores:
timings are noisy).

    python -m benchmarks.diagnose_foreign [--per-effect 3] [--seed 0] [--duration 30]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.diagnose_blind import (
    above_own_limit,
    change_time_coverage,
    commit,
    decision_table,
    own_limit_rates,
    rate,
)
from jadhesion.cli.diagnose_run import diagnose_file
from jadhesion.config import enable_compilation_cache, enable_x64
from jadhesion.diagnose.extensions import NAMES
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
#: Our parameter that estimates the foreign magnitude, and the factor between them (None: other law).
COMPARABLE = {
    "rail_change": ("drop", -1.0),
    "wheel_radius_error": ("delta_r", 1.0),
    "signal_delay": ("delay_s", 1.0),
    "torque_offset": ("offset", 1.0),
}


def limit_rates(cases) -> dict:
    """:func:`~benchmarks.diagnose_blind.own_limit_rates` of the cases (their size in our units,
    :data:`COMPARABLE` effects only)."""
    return own_limit_rates(
        [c["verdict"] == c["effect"] for c in cases], [c["above_min_detectable"] for c in cases]
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-effect", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=30.0, help="recording length [s]")
    parser.add_argument("--out", default=str(RESULTS / "diagnose_foreign.json"))
    args = parser.parse_args(argv)
    enable_x64()
    enable_compilation_cache()
    head, cases = commit(), []
    labels = ["none", *NAMES]
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.per_effect):
            for j, name in enumerate(NAMES):
                seed = args.seed * 100003 + i * len(NAMES) + j
                rec = generate(seed, effect=name, duration_s=args.duration)
                path = write(rec, Path(tmp) / f"rec_{seed}.csv", truth=False)
                start = time.perf_counter()
                d, _ = diagnose_file(path)
                seconds = time.perf_counter() - start
                recovered, covered, visible = None, None, None
                if name in COMPARABLE:  # the size in our units against the recording's own limit
                    visible = above_own_limit(d, name, COMPARABLE[name][1] * rec.truth["magnitude"])
                if name in COMPARABLE and d["verdict"] == name:
                    param, factor = COMPARABLE[name]
                    recovered = factor * d["extended"]["params"][param]
                    ci = d["extended"]["uncertainty"]["ci90"].get(param)
                    covered = ci is not None and ci[0] <= factor * rec.truth["magnitude"] <= ci[1]
                cases.append(
                    {
                        "seed": seed,
                        "effect": name,
                        "magnitude": rec.truth["magnitude"],
                        "rate_hz": rec.truth["rate_hz"],
                        "profile": rec.truth["profile"]["kind"],
                        "verdict": d["verdict"],
                        "verdict_set": d["verdict_set"],
                        "recovered": recovered,
                        "ci90_covers": covered,
                        "above_min_detectable": visible,
                        "change_time": d["extended"]["change_time"],
                        "true_change_time_s": rec.truth["effect_detail"].get("time_s"),
                        "base_mu0": d["base"]["params"]["mu0"],
                        "warnings": [w["code"] for w in d["warnings"]],
                        "top": [
                            {k: c[k] for k in ("name", "gain", "sse_reduction", "p_value", "status")}
                            for c in d["candidates"][:3]
                        ],
                        "seconds": seconds,
                        "decision": decision_table(d),
                    }
                )
                print(f"{name}: {d['verdict']} set {d['verdict_set']} ({seconds:.1f} s)", flush=True)
                confusion = {t: {p: 0 for p in labels} for t in NAMES}
                for c in cases:
                    confusion[c["effect"]][c["verdict"]] += 1
                doc = {
                    "commit": head,
                    "settings": {**vars(args), "replicas": 19, "phase": "traction", "sensors": "realistic"},
                    "loadavg_end": os.getloadavg(),
                    "confusion": confusion,
                    "per_effect": {
                        n: {
                            "top1": rate([c["verdict"] == n for c in cases if c["effect"] == n]),
                            "in_set": rate([n in c["verdict_set"] for c in cases if c["effect"] == n]),
                            "ci90_covers": rate(
                                [
                                    c["ci90_covers"]
                                    for c in cases
                                    if c["effect"] == n and c["ci90_covers"] is not None
                                ]
                            ),
                            **limit_rates([c for c in cases if c["effect"] == n]),
                        }
                        for n in NAMES
                    },
                    "single_effect": {
                        "top1": rate([c["verdict"] == c["effect"] for c in cases]),
                        **limit_rates(cases),
                    },
                    "change_time": change_time_coverage(
                        [
                            (c["change_time"], c["true_change_time_s"])
                            for c in cases
                            if c["true_change_time_s"] is not None
                        ]
                    ),
                    "cases": cases,
                }
                Path(args.out).write_text(json.dumps(doc, indent=1, default=float))
    print(f"rail change time intervals: {doc['change_time']}")
    for n, r in doc["per_effect"].items():
        print(
            f"{n:20s} top-1 {r['top1']['k']}/{r['top1']['n']}, in set {r['in_set']['k']}/{r['in_set']['n']}, "
            f"90 % interval holds the size {r['ci90_covers']['k']}/{r['ci90_covers']['n']}; "
            "above / below the recording's min_detectable: "
            + " / ".join(f"{r[k]['k']}/{r[k]['n']}" for k in r if k.endswith("_min_detectable"))
        )
    print(f"single effects: {doc['single_effect']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
