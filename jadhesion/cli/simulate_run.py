"""``jadhesion simulate``'s work: check the options, simulate, write the recording, its sidecar and
its truth, print or ``--json`` a summary (arguments: :mod:`.simulate`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..data.recording import save_recording
from ..data.scenarios import get_scenario
from ..data.sidecar import _load_sidecar
from ..data.simulator import DEFAULT_SAMPLES, SAMPLE_PERIOD, simulate
from ..data.traction_profile import COAST_EDGE_S
from ..data.validate import MAX_SPEED, _check_finite, _check_values
from ..data.vehicle import LOCO_22E
from ..errors import RecordingError
from ..models.effects import magnitudes
from ..models.polach import PARAM_NAMES
from .common import UserError, emit_json, require_in_range, require_output_file, require_seed
from .simulate import MAX_SAMPLES, MAX_SENSOR_NOISE, MIN_SAMPLES, RATE_RANGE

#: Accepted ranges of ``--params`` values (physical validity, not the fit's box): name → (lo, hi,
#: whether lo itself is allowed).
PARAM_RANGES = {
    "kA": (0.0, 1.0, False),
    "kS": (0.0, 1.0, False),
    "mu0": (0.0, 1.5, False),
    "A": (0.0, 1.0, True),
    "B": (0.0, 10.0, True),
}
#: ``--rate`` range [Hz] and the largest recording [samples].


def parse_params(text: str) -> dict:
    """``"kA=0.3,mu0=0.4"`` → ``{"kA": 0.3, "mu0": 0.4}``; :class:`UserError` naming ``--params``."""
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in PARAM_RANGES:
            raise UserError(
                f"--params {text}: expected NAME=VALUE items with NAME one of "
                f"{', '.join(PARAM_NAMES)}, got {item.strip()!r}"
            )
        if name in out:
            raise UserError(f"--params {text}: {name} given twice")
        try:
            v = float(value)
        except ValueError:
            raise UserError(f"--params {text}: {name}={value.strip()!r} is not a number") from None
        lo, hi, closed = PARAM_RANGES[name]
        if not (math.isfinite(v) and (v >= lo if closed else v > lo) and v <= hi):
            raise UserError(
                f"--params {text}: {name}={v:g} is outside {'[' if closed else '('}{lo:g}, {hi:g}]"
            )
        out[name] = v
    return out


def _samples(duration, rate) -> int:
    if not (math.isfinite(rate) and RATE_RANGE[0] <= rate <= RATE_RANGE[1]):
        raise UserError(
            f"--rate {rate:g}: expected a sample rate in [{RATE_RANGE[0]:g}, {RATE_RANGE[1]:g}] Hz"
        )
    if duration is None:
        duration = (DEFAULT_SAMPLES - 1) * SAMPLE_PERIOD
    if not (math.isfinite(duration) and duration > 0):
        raise UserError(f"--duration {duration:g}: expected a positive number of seconds")
    n = round(duration * rate) + 1
    if not MIN_SAMPLES <= n <= MAX_SAMPLES:
        raise UserError(
            f"--duration {duration:g}: gives {n} samples at {rate:g} Hz; expected "
            f"{MIN_SAMPLES} to {MAX_SAMPLES}"
        )
    return n


def _coast(seconds: float, duration: float) -> float:
    """``--coast`` [s], checked: the gap and its edges must fit in a quarter of the run on either
    side of its centre (:func:`jadhesion.data.traction_profile.coast_window`)."""
    longest = max(0.0, 0.5 * duration - 2.0 * COAST_EDGE_S)
    if not (math.isfinite(seconds) and 0.0 <= seconds <= longest):
        raise UserError(
            f"--coast {seconds:g}: expected 0 to {longest:g} s for a {duration:g} s run (half of it, "
            f"less {2.0 * COAST_EDGE_S:g} s of edges)"
        )
    return float(seconds)


def _vehicle(path):
    if path is None:
        return LOCO_22E
    p = Path(path)
    if p.suffix.lower() != ".json" or not p.is_file():
        raise UserError(f"--vehicle {path}: expected an existing sidecar .json file")
    try:
        return _load_sidecar(p.with_suffix(".csv"))[2]
    except RecordingError as exc:
        raise UserError(f"--vehicle {exc}") from None


def _readable(result, name: str) -> None:
    """Raise :class:`UserError` unless the simulated columns pass the checks a reader makes of a
    recording (finite, plausible magnitudes for its vehicle), so that simulate never writes a file
    that fit refuses: a sidecar's wheel_radius_m of 1e-300 gave an inf adhesion column and a NaN
    truth (a traceback after the recording and sidecar were written)."""
    cols = {c: np.asarray(v, float) for c, v in result.columns.items()}
    try:
        _check_values(cols, result.vehicle, None, name, MAX_SPEED, {})
        for col, values in cols.items():
            _check_finite(values, col, name)
    except RecordingError as exc:
        raise UserError(f"{exc}: the recording would not be read back") from None


def run(args) -> int:
    require_seed("simulate", args.seed)
    require_in_range("simulate", 0.0, MAX_SENSOR_NOISE, sensor_noise=args.sensor_noise)
    scenario = get_scenario(args.scenario)
    if args.params is not None:
        given = parse_params(args.params)
        scenario = scenario.replace(
            params=tuple(given.get(k, v) for k, v in zip(PARAM_NAMES, scenario.params, strict=True))
        )
    n_samples = _samples(args.duration, args.rate)
    scenario = scenario.replace(coast_s=_coast(args.coast, (n_samples - 1) / args.rate))
    vehicle = _vehicle(args.vehicle)
    magnitudes(args.effect)  # validate before any work
    require_output_file("", args.out)
    out = Path(args.out)
    for path in (out.with_suffix(".json"), out.with_suffix(".truth.json")):  # its sidecar and truth
        if path.is_dir():
            raise UserError(f"--out {args.out}: {path} (written beside it) is a directory")
    with np.errstate(all="ignore"):  # an absurd vehicle's overflow is said once, by _readable
        result = simulate(
            scenario,
            seed=args.seed,
            effects=args.effect,
            n_samples=n_samples,
            vehicle=vehicle,
            sample_period=1.0 / args.rate,
            braking=args.test == "braking",
            sensor_noise=args.sensor_noise,
        )
        _readable(result, "simulate" if args.vehicle is None else f"simulate --vehicle {args.vehicle}")
    save_recording(result.columns, result.vehicle, out)
    truth_path = out.with_suffix(".truth.json")
    truth = {**result.truth, "envelope": result.envelope}
    truth_path.write_text(json.dumps(truth, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    summary = {
        "recording": str(out),
        "sidecar": str(out.with_suffix(".json")),
        "truth": str(truth_path),
        "scenario": scenario.name,
        "seed": args.seed,
        "params": result.truth["params"],
        "test": args.test,
        "duration_s": float(f"{result.truth['duration_s']:.12g}"),  # 39.98, not 39.980000000000004
        "rate_hz": args.rate,
        "effects": result.truth["effects"],
        "coasting": result.truth["coasting"],
        "n_samples": len(result.columns["time"]),
        "envelope": result.envelope,
    }
    if args.json:
        emit_json(summary)
    else:
        env = summary["envelope"]
        print(
            f"wrote {out} ({summary['n_samples']} samples, {summary['duration_s']:g} s at "
            f"{args.rate:g} Hz, {args.test}), {out.with_suffix('.json')}, {truth_path}"
        )
        print(
            f"mean speed {env['mean_speed_kmh']:.2f} km/h, "
            f"max slip {env['max_slip_kmh']:.2f} km/h, max creep {env['max_creep']:.3f}, "
            f"mu_hat [{env['mu_low']:.3f}, {env['mu_high']:.3f}] mean {env['mu_mean']:.3f}, "
            f"true-parameter MAE {env['true_param_mae']:.4f}"
        )
        if (gap := summary["coasting"]) is not None:
            print(f"coasting gap {gap['start_s']:.2f}–{gap['end_s']:.2f} s (creep reference 0)")
    return 0
