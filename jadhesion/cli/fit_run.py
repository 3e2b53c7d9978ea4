"""``jadhesion fit``'s work: load, observe, fit, report how far to trust it (arguments: :mod:`.fit`)."""

from __future__ import annotations

import time
from pathlib import Path

import jax

from ..identify.kiencke_fit import fit_document, fit_kiencke
from ..identify.polach_fit import require_samples
from ..identify.trust import fit_report
from ..models.polach import PARAM_NAMES
from ..plots.fit import fit_figure
from ..status import status_of
from .common import UserError, emit_json, require_at_least, table
from .fit_program import fit_polach, to_dataset
from .loading import load_dataset


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


def _fit_kiencke(args, dataset) -> dict:
    start = time.perf_counter()
    fit = jax.block_until_ready(fit_kiencke(dataset, args.method, jax.random.key(args.seed),
                                            pop_size=args.pop_size, max_iter=args.max_iter))
    return {"method": args.method, **fit_document(fit), "seconds": time.perf_counter() - start}


def _fit_polach(args, dataset) -> dict:
    start = time.perf_counter()
    fit = jax.block_until_ready(fit_polach(dataset, args.method, jax.random.key(args.seed),
                                           pop_size=args.pop_size, max_iter=args.max_iter))
    seconds = time.perf_counter() - start
    status = status_of(fit.status)
    doc = {
        "model": "polach",
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
        out = Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        fit_figure(dataset, fit.params, title=f"{Path(args.file).name}: {args.method}").savefig(
            out / "fit.png", dpi=110)
    return doc


def run(args) -> int:
    """Fit one recording and print (or ``--json``) the result with its trust block."""
    _check_flags(args)
    _, dataset, selection = load_dataset(args, args.file, to_dataset)
    require_samples(dataset, args.file)
    if args.model == "kiencke":
        doc = _fit_kiencke(args, dataset)
    else:
        doc = _fit_polach(args, dataset)
    doc["creep"] = args.creep
    doc["selection"] = selection.document()
    if args.json:
        emit_json(doc)
        return 0
    print(selection.summary())
    if args.model == "kiencke":
        p = doc["params"]
        print(f"Kiencke by {args.method}: p1 {p['p1']:.5g}, p2 {p['p2']:.5g}, a_s {p['a_s']:.5g}; "
              f"mu_max {doc['mu_max']}, creep_opt {doc['creep_opt']}; MAE {doc['mae']:.5g}; "
              f"{'converged' if doc['converged'] else 'NOT CONVERGED: ' + doc['status']}")
    else:
        print(f"method {doc['method']}: MAE {doc['mae']:.5g}, {doc['iterations']} iterations, "
              f"{doc['evaluations']} evaluations, {doc['seconds']:.2f} s (compilation included)")
        print(_describe(doc))
    return 0
