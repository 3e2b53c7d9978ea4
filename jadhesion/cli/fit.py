"""``jadhesion fit FILE.csv``: identify Polach's parameters from a recording or creepage file,
with its status, standard errors, 95 % intervals, correlations and warnings."""

from __future__ import annotations

import time
from pathlib import Path

from .common import UserError, emit_json, require_at_least, table

#: Fit methods offered (the registry's names; kept literal so ``--help`` imports no JAX).
METHODS = ("itlbo", "tlbo", "pso", "lm")


def register(sub) -> None:
    p = sub.add_parser("fit", help="identify Polach's parameters [kA, kS, mu0, A, B]")
    p.add_argument("file", help="recording or creepage CSV")
    p.add_argument("--method", choices=METHODS, default="itlbo",
                   help="improved TLBO (default), TLBO, PSO or Levenberg–Marquardt")
    p.add_argument("--seed", type=int, default=0, help="optimiser seed (default 0)")
    p.add_argument("--pop-size", type=int, default=50, help="population size (default 50, >= 2)")
    p.add_argument("--max-iter", type=int, default=300,
                   help="iteration cap of a population method (default 300); it stops earlier "
                        "when its best MAE stalls")
    p.add_argument("--plot", metavar="DIR", default=None,
                   help="write fit.png (data, fit and residuals) into DIR")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=run)


def _check_flags(args) -> None:
    require_at_least("fit", 0, seed=args.seed)
    require_at_least("fit", 2, pop_size=args.pop_size)
    require_at_least("fit", 1, max_iter=args.max_iter)
    if args.plot is not None and Path(args.plot).exists() and not Path(args.plot).is_dir():
        raise UserError(f"fit: --plot {args.plot}: exists and is not a directory")


def _describe(doc) -> str:
    """The trust block in words."""
    lines = []
    if not doc["converged"]:
        lines.append(f"NOT CONVERGED: the solver stopped with status {doc['status']}")
    else:
        lines.append("converged")
    rows = []
    for name, value in doc["params"].items():
        u = doc["uncertainty"][name]
        ci = u["ci95"]
        rows.append({"parameter": name, "value": value,
                     "stderr": "on bound" if u["stderr"] is None else u["stderr"],
                     "95% interval": "-" if ci is None else f"[{ci[0]:.4g}, {ci[1]:.4g}]"})
    lines.append(table(rows, ["parameter", "value", "stderr", "95% interval"]))
    lines.append(f"standard errors: Newey–West (HAC, {doc['hac_lags']} lags), robust to the "
                 "observer's coloured residuals")
    lines += [f"warning [{w['code']}]: {w['message']}" for w in doc["warnings"]]
    return "\n".join(lines)


def run(args) -> int:
    _check_flags(args)
    import jax

    from ..data.dataset import to_dataset
    from ..data.recording import load_recording
    from ..identify.polach_fit import fit_polach, require_samples
    from ..identify.trust import fit_report
    from ..models.polach import PARAM_NAMES
    from ..status import status_of

    dataset = to_dataset(load_recording(args.file))
    require_samples(dataset, args.file)
    start = time.perf_counter()
    fit = jax.block_until_ready(fit_polach(dataset, args.method, jax.random.key(args.seed),
                                           pop_size=args.pop_size, max_iter=args.max_iter))
    seconds = time.perf_counter() - start
    status = status_of(fit.status)
    doc = {
        "method": args.method,
        "params": dict(zip(PARAM_NAMES, map(float, fit.params))),
        "mae": float(fit.mae),
        "iterations": int(fit.iterations),
        "evaluations": int(fit.evaluations),
        "seconds": seconds,
        "status": status.label,
        "converged": status.converged,
        **fit_report(dataset, fit),
    }
    if args.plot is not None:
        from ..plots.fit import fit_figure

        out = Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        fit_figure(dataset, fit.params, title=f"{Path(args.file).name}: {args.method}").savefig(
            out / "fit.png", dpi=110)
    if args.json:
        emit_json(doc)
    else:
        print(f"method {doc['method']}: MAE {doc['mae']:.5g}, {doc['iterations']} iterations, "
              f"{doc['evaluations']} evaluations, {seconds:.2f} s (compilation included)")
        print(_describe(doc))
    return 0
