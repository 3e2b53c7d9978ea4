"""``jadhesion simulate``: a simulated 22E traction- or braking-test recording (CSV + sidecar + truth).

Writes ``FILE.csv`` (``time``, ``vehicle_speed``, ``wheel_speed``, ``traction_torque`` plus the
convenience columns ``creepage``, ``slip_velocity``, ``adhesion``; SI units), its vehicle sidecar
``FILE.json`` (DESIGN §3 keys) and ``FILE.truth.json`` (scenario, seed, true parameters, vehicle,
duration, rate, test, effects, noise levels, envelope statistics).

Researchers' options: ``--params kA=…,mu0=…`` replaces any subset of the scenario's Polach
parameters (the rest, the creep profile and the noise stay the scenario's); ``--duration`` [s] and
``--rate`` [Hz] set the recording's length and sampling; ``--vehicle SIDECAR.json`` a locomotive
(sidecar keys, missing ones 22E); ``--test braking`` negates the creep reference (negative torque);
``--coast S`` adds an S-second coasting gap (:func:`jadhesion.data.traction_profile.coast_window`).

This module defines the arguments only; :mod:`.simulate_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS

#: The names of :data:`jadhesion.data.scenarios.SCENARIOS` and
#: :data:`jadhesion.models.effects.EFFECT_NAMES`, and the simulator's default rate [Hz] and length
#: [s] (:data:`~jadhesion.data.simulator.SAMPLE_PERIOD`, ``DEFAULT_SAMPLES``), for the help text
#: only: those modules import JAX; a test keeps these equal to them.
SCENARIO_NAMES = ("dry", "wet", "sand")
#: The sample rates [Hz] and the recording lengths [samples] ``simulate`` accepts.
RATE_RANGE = (10.0, 1000.0)
MIN_SAMPLES, MAX_SAMPLES = 100, 200_000
EFFECT_NAMES = (
    "rail_change",
    "wheel_radius_error",
    "signal_delay",
    "speed_dependence",
    "torque_offset",
    "thermal_softening",
    "load_transfer",
)
DEFAULT_RATE_HZ = 50.0
DEFAULT_DURATION_S = 39.98
#: The largest ``--sensor-noise``: 10× the realistic sensors puts the speed noise at 1e-2 m/s, the
#: noisiest of the survey (:mod:`jadhesion.data.sensors`), and μ̂ already dips below 0 on a dry
#: run; 100× gave μ̂ from −4.4 to 4.5 and torques of ±580 kN·m.
MAX_SENSOR_NOISE = 10.0


def register(sub) -> None:
    """Add the ``simulate`` subcommand to ``sub`` (argparse subparsers)."""
    p = sub.add_parser("simulate", help=COMMANDS["simulate"])
    p.add_argument("--scenario", default="dry", help=f"one of {', '.join(SCENARIO_NAMES)} (default dry)")
    p.add_argument(
        "--params",
        default=None,
        metavar="kA=…,kS=…,mu0=…,A=…,B=…",
        help="Polach parameters replacing the scenario's (any subset)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help=f"recording length [s] (default {DEFAULT_DURATION_S:g}; {MIN_SAMPLES} to {MAX_SAMPLES:,} "
        "samples)",
    )
    p.add_argument(
        "--rate",
        type=float,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help=f"sample rate [Hz] (default {DEFAULT_RATE_HZ:g}; {RATE_RANGE[0]:g} to {RATE_RANGE[1]:g})",
    )
    p.add_argument(
        "--vehicle",
        default=None,
        metavar="SIDECAR.json",
        help="locomotive as a sidecar JSON (missing keys: 22E defaults)",
    )
    p.add_argument(
        "--test",
        choices=("traction", "braking"),
        default="traction",
        help="traction (default) or braking (negative creep and torque)",
    )
    p.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="NAME[=MAGNITUDE]",
        help=f"add an effect (repeatable): {', '.join(EFFECT_NAMES)}",
    )
    p.add_argument(
        "--coast",
        type=float,
        default=0.0,
        metavar="S",
        help="a coasting gap of S seconds: the creep reference taken to 0 at a quarter or three "
        "quarters of the run, away from the main slip excursion (the run that reads a torque "
        "offset; default 0, none)",
    )
    p.add_argument("--seed", type=int, default=0, help="PRNG seed, 0 to 2**63 - 1 (default 0)")
    p.add_argument(
        "--sensor-noise",
        type=float,
        default=1.0,
        metavar="SCALE",
        help=f"scale of the realistic sensor noise, 0 (none) to {MAX_SENSOR_NOISE:g} "
        "(jadhesion.data.sensors; default 1)",
    )
    p.add_argument("--out", required=True, metavar="FILE.csv", help="recording to write")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(handler="jadhesion.cli.simulate_run:run")
