"""``jadhesion reproduce``'s work: run Table 2 and/or the online study, print or ``--json`` them
(arguments: :mod:`.reproduce`)."""

from __future__ import annotations

from ..experiments import online, table2
from .common import Progress, emit_json, require_at_least


def run(args) -> int:
    """Reproduce the requested target(s) on the built-in defaults."""
    require_at_least("reproduce", 1, seeds=args.seeds, runs=args.runs)
    require_at_least("reproduce", table2.MCMC_MIN_STEPS, mcmc_steps=args.mcmc_steps)
    out = {}
    if args.target in (None, "table2"):
        with Progress(label="table2", unit="cells") as progress:
            out["table2"] = table2.run(
                seeds=args.seeds,
                plot_dir=args.plot,
                progress=progress,
                mcmc=not args.no_mcmc,
                mcmc_steps=args.mcmc_steps,
            )
    if args.target in (None, "online"):
        with Progress(label="online Monte Carlo", unit="configs") as progress:
            out["online"] = online.run(runs=args.runs, plot_dir=args.plot, progress=progress)
    if args.json:
        emit_json(out[args.target] if args.target else out)
    else:
        for name, result in out.items():
            module = table2 if name == "table2" else online
            print(module.format_text(result))
    return 0
