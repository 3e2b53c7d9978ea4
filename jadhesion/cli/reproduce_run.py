"""``jadhesion reproduce``'s work: run Table 2 and/or the online study, print or ``--json`` them
(arguments: :mod:`.reproduce`)."""

from __future__ import annotations

import sys

from ..experiments import online, online_text, table2, table2_text
from ..experiments.mcmc_row import MCMC_MIN_STEPS
from .common import Progress, emit_json, require_in_range, require_output_dir
from .reproduce import DEFAULT_RUNS, DEFAULT_SEEDS, MAX_MCMC_STEPS, MAX_RUNS, MAX_SEEDS, MAX_SENSOR_NOISE

#: Table 2's flags and their defaults (the online study takes none of them).
TABLE2_FLAGS = {
    "seeds": DEFAULT_SEEDS,
    "no_mcmc": False,
    "mcmc_steps": None,
    "sensors": "clean",
    "sensor_noise": 1.0,
}


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def ignored_flags(args) -> list[str]:
    """Warnings for the flags given (off their defaults) that this run does not use, said rather
    than silently dropped: table2's with ``online``, ``--runs`` with ``table2``, ``--mcmc-steps``
    with ``--no-mcmc``, ``--sensor-noise`` on clean sensors."""
    notes = []
    if args.target == "online":
        stray = [_flag(k) for k, default in TABLE2_FLAGS.items() if getattr(args, k) != default]
        if stray:
            notes.append(f"{', '.join(stray)}: table2's, ignored by reproduce online")
        return notes
    if args.target == "table2" and args.runs != DEFAULT_RUNS:
        notes.append("--runs: the online study's, ignored by reproduce table2")
    if args.no_mcmc and args.mcmc_steps is not None:
        notes.append("--mcmc-steps ignored with --no-mcmc")
    if args.sensors == "clean" and args.sensor_noise != TABLE2_FLAGS["sensor_noise"]:
        notes.append("--sensor-noise scales the realistic sensors: ignored without --sensors realistic")
    return notes


def run(args) -> int:
    """Reproduce the requested target(s) on the built-in defaults."""
    require_in_range("reproduce", 1, MAX_SEEDS, seeds=args.seeds)
    require_in_range("reproduce", 1, MAX_RUNS, runs=args.runs)
    require_in_range("reproduce", MCMC_MIN_STEPS, MAX_MCMC_STEPS, mcmc_steps=args.mcmc_steps)
    require_in_range("reproduce", 0.0, MAX_SENSOR_NOISE, sensor_noise=args.sensor_noise)  # simulate's
    require_output_dir("reproduce", "plot", args.plot)
    for note in ignored_flags(args):
        sys.stderr.write(f"jadhesion: warning: {note}\n")
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
