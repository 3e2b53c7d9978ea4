"""``jadhesion simulate``: a simulated 22E traction-test recording (CSV + sidecar + truth file).

Writes ``FILE.csv`` (``time``, ``vehicle_speed``, ``wheel_speed``, ``traction_torque`` plus the
convenience columns ``creepage``, ``slip_velocity``, ``adhesion``; SI units), its vehicle sidecar
``FILE.json`` (DESIGN §3 keys) and ``FILE.truth.json`` (scenario, seed, true parameters, effects,
noise levels, envelope statistics).
"""

from __future__ import annotations

import json
from pathlib import Path

from .common import UserError, emit_json

RECORDING_COLUMNS = ("time", "vehicle_speed", "wheel_speed", "traction_torque", "creepage",
                     "slip_velocity", "adhesion")


def register(sub) -> None:
    from ..data.scenarios import SCENARIOS
    from ..models.effects import EFFECT_NAMES

    p = sub.add_parser("simulate", help="simulate a 22E traction-test recording")
    p.add_argument("--scenario", required=True, help=f"one of {', '.join(SCENARIOS)}")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[=MAGNITUDE]",
                   help=f"add an effect (repeatable): {', '.join(EFFECT_NAMES)}")
    p.add_argument("--seed", type=int, default=0, help="PRNG seed (default 0)")
    p.add_argument("--sensor-noise", type=float, default=1.0, metavar="SCALE",
                   help="scale of the realistic sensor noise (jadhesion.data.sensors; 0: none)")
    p.add_argument("--out", required=True, metavar="FILE.csv", help="recording to write")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..data.recording import save_recording
    from ..data.scenarios import get_scenario
    from ..data.simulator import simulate
    from ..models.effects import magnitudes

    scenario = get_scenario(args.scenario)
    magnitudes(args.effect)  # validate before any work
    out = Path(args.out)
    if out.suffix.lower() != ".csv":
        raise UserError(f"--out {args.out}: expected a .csv file name")
    if not out.parent.is_dir():
        raise UserError(f"--out {args.out}: directory {str(out.parent)!r} does not exist")
    if not args.sensor_noise >= 0.0:
        raise UserError(f"--sensor-noise {args.sensor_noise}: expected a scale >= 0")
    result = simulate(scenario, seed=args.seed, effects=args.effect, sensor_noise=args.sensor_noise)
    save_recording({k: result.columns[k] for k in RECORDING_COLUMNS}, result.vehicle, out)
    truth_path = out.with_suffix(".truth.json")
    truth_path.write_text(json.dumps(result.truth, indent=2, allow_nan=False) + "\n",
                          encoding="utf-8")
    summary = {"recording": str(out), "sidecar": str(out.with_suffix(".json")),
               "truth": str(truth_path), "scenario": scenario.name, "seed": args.seed,
               "effects": result.truth["effects"], "n_samples": len(result.columns["time"]),
               "envelope": result.truth["envelope"]}
    if args.json:
        emit_json(summary)
    else:
        env = summary["envelope"]
        print(f"wrote {out} ({summary['n_samples']} samples), {out.with_suffix('.json')}, "
              f"{truth_path}")
        print(f"mean speed {env['mean_speed_kmh']:.2f} km/h, "
              f"max slip {env['max_slip_kmh']:.2f} km/h, max creep {env['max_creep']:.3f}, "
              f"mu_hat [{env['mu_low']:.3f}, {env['mu_high']:.3f}] mean {env['mu_mean']:.3f}, "
              f"true-parameter MAE {env['true_param_mae']:.4f}")
    return 0
