"""``jadhesion fit FILE.csv``: identify Polach's parameters from a recording or creepage file."""

from __future__ import annotations

import time

from .common import emit_json, table
from .recording_options import add_recording_options, load_from_args

METHODS = ("itlbo", "tlbo", "pso", "lm")


def register(sub) -> None:
    p = sub.add_parser("fit", help="identify Polach's parameters [kA, kS, mu0, A, B]")
    p.add_argument("file", help="recording or creepage CSV")
    p.add_argument("--method", choices=METHODS, default="itlbo",
                   help="improved TLBO (default), TLBO, PSO or Levenberg–Marquardt")
    p.add_argument("--seed", type=int, default=0, help="optimiser seed (default 0)")
    p.add_argument("--pop-size", type=int, default=50, help="population size (default 50)")
    p.add_argument("--max-iter", type=int, default=300, help="iteration budget (default 300)")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    add_recording_options(p)
    p.set_defaults(func=run)


def run(args) -> int:
    import jax

    from ..data.dataset import to_dataset
    from ..identify.polach_fit import fit_polach
    from ..models.polach import PARAM_NAMES

    dataset = to_dataset(load_from_args(args, args.file))
    start = time.perf_counter()
    fit = jax.block_until_ready(fit_polach(dataset, args.method, jax.random.key(args.seed),
                                           pop_size=args.pop_size, max_iter=args.max_iter))
    seconds = time.perf_counter() - start
    doc = {
        "method": args.method,
        "params": dict(zip(PARAM_NAMES, map(float, fit.params))),
        "mae": float(fit.mae),
        "iterations": int(fit.iterations),
        "evaluations": int(fit.evaluations),
        "seconds": seconds,
    }
    if args.json:
        emit_json(doc)
    else:
        rows = [{"parameter": k, "value": v} for k, v in doc["params"].items()]
        print(table(rows, ["parameter", "value"]))
        print(f"method {doc['method']}: MAE {doc['mae']:.5g}, {doc['iterations']} iterations, "
              f"{doc['evaluations']} evaluations, {seconds:.2f} s (compilation included)")
    return 0
