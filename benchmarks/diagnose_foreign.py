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

``--generator kinematic`` conceals instead the three effects the kinematic generator
(:mod:`validation.kinematic_generator`) prescribes — rail change, wheel-radius error, torque offset,
in our units — in its mainline and braking runs (alternately; braking diagnosed with ``--phase
braking``), each with random Polach parameters, vehicle, logger rate (20–200 Hz) and white speed
noise (0.002–0.02 m/s) as ``benchmarks.diagnose_null`` draws them, and magnitudes log-uniform over
the catalogue's typical range (:attr:`jadhesion.models.effect_spec.EffectSpec.typical`; a random
sign where the effect is signed).

    python -m benchmarks.diagnose_foreign [--per-effect 3] [--seed 0] [--duration 30]
        [--generator foreign|kinematic]
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
from jadhesion.models.effects import EFFECTS
from validation import kinematic_generator
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
#: Our parameter that estimates the foreign magnitude, and the factor between them (None: other law).
COMPARABLE = {
    "rail_change": ("drop", -1.0),
    "wheel_radius_error": ("delta_r", 1.0),
    "signal_delay": ("delay_s", 1.0),
    "torque_offset": ("offset", 1.0),
}


#: The kinematic generator's effects are in our units: each magnitude is its parameter's.
KINEMATIC = {
    "rail_change": ("drop", 1.0),
    "wheel_radius_error": ("delta_r", 1.0),
    "torque_offset": ("offset", 1.0),
}


def foreign_case(seed: int, name: str, directory, duration: float):
    """The independent generator's recording with effect ``name``: ``(path, phase, truth)``."""
    rec = generate(seed, effect=name, duration_s=duration)
    truth = {
        "magnitude": rec.truth["magnitude"],
        "rate_hz": rec.truth["rate_hz"],
        "profile": rec.truth["profile"]["kind"],
        "change_time_s": rec.truth["effect_detail"].get("time_s"),
    }
    return write(rec, Path(directory) / f"rec_{seed}.csv", truth=False), "traction", truth


def kinematic_case(seed: int, name: str, directory, duration: float):
    """The kinematic generator's recording with effect ``name`` (module docstring): ``(path, phase,
    truth)``."""
    rng = np.random.default_rng([seed, 17])
    kind = ("mainline", "braking")[seed % 2]
    lo, hi = EFFECTS[name].typical
    magnitude = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    if EFFECTS[name].signed:
        magnitude *= float(rng.choice([-1.0, 1.0]))
    settings = kinematic_generator.random_settings(rng)
    rec = kinematic_generator.generate(
        seed, kind, duration_s=duration, effect=name, magnitude=magnitude, **settings
    )
    truth = {
        "magnitude": magnitude,
        "rate_hz": rec.truth["rate_hz"],
        "profile": kind,
        # on the recording's own clock, as the diagnosis reports it: ms since the epoch
        "change_time_s": None
        if rec.truth["change_time_s"] is None
        else kinematic_generator.EPOCH_MS / 1e3 + rec.truth["change_time_s"],
        "speed_noise_m_s": rec.truth["speed_noise_m_s"],
    }
    path = kinematic_generator.write(rec, Path(directory) / f"kinematic_{seed}.csv")
    return path, kinematic_generator.phase(kind), truth


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
    parser.add_argument("--generator", choices=("foreign", "kinematic"), default="foreign")
    parser.add_argument("--out", default=str(RESULTS / "diagnose_foreign.json"))
    args = parser.parse_args(argv)
    kinematic = args.generator == "kinematic"
    names, comparable = (tuple(KINEMATIC), KINEMATIC) if kinematic else (NAMES, COMPARABLE)
    make = kinematic_case if kinematic else foreign_case
    enable_x64()
    enable_compilation_cache()
    head, cases = commit(), []
    labels = ["none", *NAMES]
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.per_effect):
            for j, name in enumerate(names):
                seed = args.seed * 100003 + i * len(names) + j
                path, phase, truth = make(seed, name, tmp, args.duration)
                start = time.perf_counter()
                d, _ = diagnose_file(path, phase=phase)
                seconds = time.perf_counter() - start
                recovered, covered, visible = None, None, None
                if name in comparable:  # the size in our units against the recording's own limit
                    visible = above_own_limit(d, name, comparable[name][1] * truth["magnitude"])
                if name in comparable and d["verdict"] == name:
                    param, factor = comparable[name]
                    recovered = factor * d["extended"]["params"][param]
                    ci = d["extended"]["uncertainty"]["ci90"].get(param)
                    covered = ci is not None and ci[0] <= factor * truth["magnitude"] <= ci[1]
                cases.append(
                    {
                        "seed": seed,
                        "effect": name,
                        "phase": phase,
                        **truth,
                        "verdict": d["verdict"],
                        "verdict_set": d["verdict_set"],
                        "recovered": recovered,
                        "ci90_covers": covered,
                        "above_min_detectable": visible,
                        "change_time": d["extended"]["change_time"],
                        "true_change_time_s": truth["change_time_s"],
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
                confusion = {t: {p: 0 for p in labels} for t in names}
                for c in cases:
                    confusion[c["effect"]][c["verdict"]] += 1
                doc = {
                    "commit": head,
                    "settings": {
                        **vars(args),
                        "replicas": 19,
                        "phase": "braking on braking runs" if kinematic else "traction",
                        "sensors": "white, 0.002–0.02 m/s" if kinematic else "realistic",
                    },
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
                        for n in names
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
