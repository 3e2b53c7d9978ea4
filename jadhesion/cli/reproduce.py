"""``jadhesion reproduce [table2|online]``: the papers' results on built-in defaults.

With no target it runs both: paper 001's Table 2 (Polach, offline) and paper 000's online
identification (Kiencke). Table 2 gains one ``mcmc`` row per scenario (the emcee posterior,
:func:`jadhesion.experiments.table2.mcmc_row`) unless ``--no-mcmc``.
"""

from __future__ import annotations

import sys

from ..experiments import online, table2
from .common import Progress, emit_json, require_at_least


def register(sub) -> None:
    p = sub.add_parser("reproduce", help="reproduce the papers' tables (default: both)")
    p.add_argument("target", nargs="?", choices=("table2", "online"), default=None)
    p.add_argument("--seeds", type=int, default=20, help="table2: data/optimiser seeds per cell")
    p.add_argument("--runs", type=int, default=1000, help="online: Monte Carlo runs per algorithm")
    p.add_argument("--no-mcmc", action="store_true",
                   help="table2: leave out the emcee posterior row of each scenario")
    p.add_argument("--mcmc-steps", type=int, default=None, metavar="S",
                   help="table2: steps of each posterior chain (default 1500; burn-in a third)")
    p.add_argument("--plot", metavar="DIR", default=None, help="write figures into DIR")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=run)


def _bar(label: str, enabled: bool):
    """A ``progress(done, total)`` callback drawing a :class:`Progress` line on stderr."""
    bars = []

    def update(done: int, total: int) -> None:
        if not bars:
            bars.append(Progress(total, label, "configs", enabled=enabled))
        bars[0].update(done - bars[0].done)
    return update


def run(args) -> int:
    require_at_least("reproduce", 1, seeds=args.seeds, runs=args.runs)
    require_at_least("reproduce", table2.MCMC_MIN_STEPS, mcmc_steps=args.mcmc_steps)
    out = {}
    progress = not args.json or sys.stderr.isatty()
    if args.target in (None, "table2"):
        out["table2"] = table2.run(seeds=args.seeds, plot_dir=args.plot, progress=progress,
                                   mcmc=not args.no_mcmc, mcmc_steps=args.mcmc_steps)
    if args.target in (None, "online"):
        out["online"] = online.run(runs=args.runs, plot_dir=args.plot,
                                   progress=_bar("online Monte Carlo", progress))
    if args.json:
        emit_json(out[args.target] if args.target else out)
    else:
        for name, result in out.items():
            module = table2 if name == "table2" else online
            print(module.format_text(result))
    return 0
