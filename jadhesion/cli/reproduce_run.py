"""``jadhesion reproduce``'s work: run Table 2 and/or the online study, print or ``--json`` them
(arguments: :mod:`.reproduce`)."""

from __future__ import annotations

from ..experiments import online, online_text, table2, table2_text
from ..experiments.mcmc_row import MCMC_MIN_STEPS
from .common import Progress, emit_json, require_in_range, require_output_dir
from .reproduce import MAX_MCMC_STEPS, MAX_RUNS, MAX_SEEDS, MAX_SENSOR_NOISE


def run(args) -> int:
    """Reproduce the requested target(s) on the built-in defaults."""
    require_in_range("reproduce", 1, MAX_SEEDS, seeds=args.seeds)
    require_in_range("reproduce", 1, MAX_RUNS, runs=args.runs)
    require_in_range("reproduce", MCMC_MIN_STEPS, MAX_MCMC_STEPS, mcmc_steps=args.mcmc_steps)
    require_in_range("reproduce", 0.0, MAX_SENSOR_NOISE, sensor_noise=args.sensor_noise)  # simulate's
    require_output_dir("reproduce", "plot", args.plot)
    out = {}
    if args.target in (None, "table2"):
        with Progress(label="table2", unit="cells") as progress:
            out["table2"] = table2.run(
                seeds=args.seeds,
                plot_dir=args.plot,
                progress=progress,
                mcmc=not args.no_mcmc,
                mcmc_steps=args.mcmc_steps,
                sensors=args.sensors,
                sensor_noise=args.sensor_noise,
            )
    if args.target in (None, "online"):
        with Progress(label="online Monte Carlo", unit="configs") as progress:
            out["online"] = online.run(runs=args.runs, plot_dir=args.plot, progress=progress)
    if args.json:
        emit_json(out[args.target] if args.target else out)
    else:
        for name, result in out.items():
            print((table2_text if name == "table2" else online_text).format_text(result))
    return 0
