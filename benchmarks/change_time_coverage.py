"""Coverage of the rail change's time interval (``extended.change_time``,
:mod:`jadhesion.diagnose.change_time`) on both generators, through the CLI's code path.

``--per`` recordings per generator with a concealed rail change: our simulator's (random
scenario, vehicle and, with probability 0.5, a varied driving profile; magnitude log-uniform over
``--magnitudes``, the change at the simulator's fixed time) and the independent generator's
(:mod:`validation.foreign_generator`: its own profiles, sampling rates and sensors; its magnitude
and time, 35–65 % of the run, drawn by it). Reported per generator: how many changes were named,
how many of their 90 % intervals hold the true time (k/n with a 95 % Clopper–Pearson interval),
the fitted time inside its own interval, the intervals' median width, and how often the drop's
90 % interval (``extended.uncertainty``) holds the true drop; per case the verdict, the intervals
and the truth. The result file records the commit and the settings.

    python -m benchmarks.change_time_coverage [--per 15] [--seed 0] [--duration 30]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.diagnose_blind import change_time_coverage, commit, rate
from jadhesion.cli.common import Progress
from jadhesion.cli.diagnose_run import diagnose_file
from jadhesion.config import enable_compilation_cache, enable_x64
from validation.diagnose_cases import run_case
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"


def _case(generator: str, seed: int, drop: float, true_time: float, d: dict) -> dict:
    """One recording's row: the truth (``drop`` [-] in our extension's sign: μ0 falls by it), the
    verdict, the time interval and whether it and the drop's 90 % interval hold the truth."""
    found = d["extended"]["change_time"]
    ci = d["extended"]["uncertainty"]["ci90"].get("drop")
    return {
        "generator": generator,
        "seed": seed,
        "drop": drop,
        "drop_fitted": d["extended"]["params"].get("drop"),
        "drop_ci90": ci,
        "drop_covered": None if ci is None else bool(ci[0] <= drop <= ci[1]),
        "true_time_s": true_time,
        "verdict": d["verdict"],
        "effects": d["effects"],
        "t_change_s": d["extended"]["params"].get("t_change_s"),
        "change_time": found,
        "covered": None
        if not found
        else bool(found["t_change_interval_s"][0] <= true_time <= found["t_change_interval_s"][1]),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per", type=int, default=15, help="recordings per generator (default 15)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=30.0, help="independent generator's length [s]")
    parser.add_argument(
        "--magnitudes",
        type=float,
        nargs=2,
        default=(0.12, 0.5),
        help="our simulator's drop range (log-uniform)",
    )
    parser.add_argument("--out", default=str(RESULTS / "change_time_coverage.json"))
    args = parser.parse_args(argv)
    enable_x64()
    enable_compilation_cache()
    rng = np.random.default_rng(args.seed)
    cases, head = [], commit()  # the code this process imported
    progress = Progress(2 * args.per, "diagnoses", enabled=sys.stderr.isatty())
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.per):
            lo, hi = np.log(args.magnitudes)
            m = float(np.exp(rng.uniform(lo, hi)))
            case = run_case([("rail_change", m)], rng, tmp, p_varied_profile=0.5)
            t_true = case["truth"]["rail_change"]["time_s"]
            cases.append(_case("ours", case["seed"], m, t_true, case["diagnosis"]))
            progress.update()
            seed = 200003 * (args.seed + 1) + i
            rec = generate(seed, effect="rail_change", duration_s=args.duration)
            d, _ = diagnose_file(write(rec, Path(tmp) / f"rec_{seed}.csv", truth=False))
            drop = -rec.truth["magnitude"]  # its rail change is μ0 → μ0 (1 + m)
            cases.append(_case("foreign", seed, drop, rec.truth["effect_detail"]["time_s"], d))
            progress.update()
            doc = {
                "commit": head,
                "settings": {**vars(args), "replicas": 19, "p_varied_profile": 0.5},
                "coverage": {
                    g: change_time_coverage(
                        [(c["change_time"], c["true_time_s"]) for c in cases if c["generator"] == g]
                    )
                    for g in ("ours", "foreign")
                },
                "drop_ci90": {
                    g: rate(
                        [
                            c["drop_covered"]
                            for c in cases
                            if c["generator"] == g and c["drop_covered"] is not None
                        ]
                    )
                    for g in ("ours", "foreign")
                },
                "cases": cases,
            }
            Path(args.out).write_text(json.dumps(doc, indent=1, default=float))
    progress.close()
    for g, r in doc["coverage"].items():
        print(f"{g}: time {r}; drop's 90 % interval holds it {doc['drop_ci90'][g]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
