"""Effects the Polach curve alone does not explain (DESIGN §3 catalogue; names are a contract).

Every effect has a name and one magnitude; a magnitude of 0 is exactly "no effect", so the
simulator carries all of them as one vector (:func:`magnitudes`) and compiles once for any mix.
Each factor below is a pure function of that magnitude (jit/vmap/grad-able).

=====================  ========================================================  ===========
name                   physics (equation)                                        default mag
=====================  ========================================================  ===========
rail_change            ``mu0 → mu0 (1 − m)`` from ``t_c`` on (a step, smoothed    0.2
                       over :data:`RAIL_STEP_WIDTH`); ``t_c`` = :data:`RAIL_CHANGE_AT`
                       of the recording. Contaminant patch; typically 0.1–0.5.
wheel_radius_error     true rolling radius ``r = r_nom (1 + m)``; the recorded     0.01
                       wheel speed uses ``r_nom``: recorded slip is lower by
                       ``m·v_w`` (offset ∝ speed) and ``mu_hat`` is scaled by
                       ``(1 + m)`` (torque→force). Wear 1220→1180 mm: m ≈ −0.03.
signal_delay           recorded torque lags the speed signals: ``T_rec(t) =        0.05 s
                       T(t − m)``, m in seconds (TCU torque estimate, bus
                       latency); typically 10–100 ms.
speed_dependence       Curtius–Kniffler-like ``mu0(v) = mu0 (1 − m (v − v_ref)/     0.3
                       v_ref)``, ``v_ref`` the scenario's mean speed (floored at
                       5 % of mu0). C–K gives m ≈ 0.1–0.5 around walking speed.
torque_offset          additive torque bias ``T_rec = T + m · m_axle g r``: an     0.02
                       adhesion-coefficient offset ``m`` in ``mu_hat``
                       (current-sensor / torque-model bias).
thermal_softening      ``mu0 → mu0 / (1 + m P_th / P_ref)``, ``P_ref`` =          0.5
                       :data:`THERMAL_POWER_SCALE`, with the first-order thermal
                       state ``τ Ṗ_th = mu N |w| − P_th`` (frictional power,
                       ``τ`` = :data:`THERMAL_TIME_CONSTANT`).
load_transfer          the measured (leading) axle unloads with tractive effort:   0.5
                       ``N1 = N (1 − m F_t/(M g))``, ``F_t = n T / r`` (equal to
                       ``M a`` without a trailing load); Hertz: ``k_eps ∝
                       N1^(−1/3)``. Bogie pitch gives m ≈ 0.3–1.
=====================  ========================================================  ===========
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import InputError


class EffectSpec(NamedTuple):
    """One effect's record in the registry: everything the code knows about it in one place.

    ``default``/``low``/``high`` — the simulator's default magnitude and allowed interval; ``unit``;
    ``summary`` (one line); ``typical`` — the log-uniform |magnitude| range of blind cases and of
    the sensitivity's "visible at typical magnitudes"; ``signed`` — the sign is drawn at random;
    ``signal`` — the recording signal its residual signature follows
    (:func:`jadhesion.diagnose.features.library` key); ``exposing_run`` — the run that exposes it
    when a recording cannot.
    """

    name: str
    default: float
    low: float
    high: float
    unit: str
    summary: str
    typical: tuple
    signed: bool
    signal: str
    exposing_run: str


EFFECTS = {
    spec.name: spec
    for spec in (
        EffectSpec(
            "rail_change",
            0.2,
            0.0,
            0.95,
            "-",
            "relative drop of mu0 at a step in time",
            (0.02, 0.5),
            False,
            "time",
            "a run over each rail section separately",
        ),
        EffectSpec(
            "wheel_radius_error",
            0.01,
            -0.2,
            0.2,
            "-",
            "true radius = nominal · (1 + m)",
            (0.002, 0.05),
            True,
            "speed",
            "a coasting run at two speeds, where creep grows with speed without torque",
        ),
        EffectSpec(
            "signal_delay",
            0.05,
            0.0,
            2.0,
            "s",
            "torque lags the speed signals by m seconds",
            (0.01, 0.3),
            False,
            "torque_rate",
            "a torque step, timed against the wheel acceleration",
        ),
        EffectSpec(
            "speed_dependence",
            0.3,
            -2.0,
            2.0,
            "-",
            "mu0 falls by m per relative speed rise",
            (0.05, 1.0),
            True,
            "speed",
            "a speed sweep at constant creep",
        ),
        EffectSpec(
            "torque_offset",
            0.02,
            -0.3,
            0.3,
            "-",
            "torque bias as an adhesion offset",
            (0.002, 0.05),
            True,
            "adhesion",
            "a coasting run, where zero torque reads the bias",
        ),
        EffectSpec(
            "thermal_softening",
            0.5,
            0.0,
            10.0,
            "-",
            "mu0 / (1 + m · P_th / P_ref)",
            (0.05, 3.0),
            False,
            "heat",
            "a repeat run after a pause, when a thermal drop has recovered",
        ),
        EffectSpec(
            "load_transfer",
            0.5,
            -2.0,
            2.0,
            "-",
            "N1 = N (1 − m · F_t / (M g))",
            (0.1, 1.5),
            False,
            "traction_ratio",
            "a run with the other axles' torque changed independently (one bogie coasting), "
            "so that tractive effort no longer follows this axle's adhesion",
        ),
    )
}
EFFECT_NAMES = tuple(EFFECTS)
INDEX = {name: i for i, name in enumerate(EFFECT_NAMES)}

#: Time of the rail change as a fraction of the recording [-], and its smoothing width [s].
RAIL_CHANGE_AT = 0.5
RAIL_STEP_WIDTH = 0.05
#: Thermal softening: time constant [s] and reference frictional power [W].
THERMAL_TIME_CONSTANT = 2.0
THERMAL_POWER_SCALE = 10e3


def magnitudes(effects=()) -> np.ndarray:
    """Magnitudes over :data:`EFFECT_NAMES` (0 = off) from ``[(name, mag) | name | "name=mag"]``.

    Raises:
        InputError: unknown name, magnitude not a finite number or outside the effect's interval,
            or an effect given twice.
    """
    out = np.zeros(len(EFFECT_NAMES))
    seen = set()
    for item in effects:
        if isinstance(item, str):
            name, _, text = item.partition("=")
            mag = text if text else None
        else:
            name, mag = item
        name = name.strip()
        if name not in EFFECTS:
            raise InputError(f"unknown effect {name!r}; expected one of {', '.join(EFFECT_NAMES)}")
        if name in seen:
            raise InputError(f"effect {name!r} given twice")
        seen.add(name)
        spec = EFFECTS[name]
        try:
            value = spec.default if mag is None else float(mag)
        except (TypeError, ValueError):
            raise InputError(f"effect {name!r}: magnitude {mag!r} is not a number") from None
        if not (np.isfinite(value) and spec.low <= value <= spec.high):
            unit = "" if spec.unit == "-" else f" {spec.unit}"
            raise InputError(f"effect {name!r}: magnitude {value} outside [{spec.low}, {spec.high}]{unit}")
        out[INDEX[name]] = value
    return out


def rail_factor(mag, time, t_change):
    """``mu0`` multiplier of ``rail_change``: ``1 − m · σ((t − t_c)/width)`` (logistic step)."""
    return 1.0 - mag * jax.nn.sigmoid((time - t_change) / RAIL_STEP_WIDTH)


def speed_factor(mag, speed, v_ref):
    """``mu0`` multiplier of ``speed_dependence``: ``max(1 − m (v − v_ref)/v_ref, 0.05)``."""
    return jnp.maximum(1.0 - mag * (speed - v_ref) / v_ref, 0.05)


def thermal_factor(mag, heat):
    """``mu0`` multiplier of ``thermal_softening``: ``1 / (1 + m P_th / P_ref)``, ``P_th`` [W]."""
    return 1.0 / (1.0 + mag * jnp.maximum(heat, 0.0) / THERMAL_POWER_SCALE)


def load_factor(mag, traction_ratio):
    """Leading-axle load multiplier of ``load_transfer``: ``1 − m F_t/(M g)`` (floored at 0.1)."""
    return jnp.maximum(1.0 - mag * traction_ratio, 0.1)


def delayed(time, signal, delay):
    """``signal(t − delay)`` by linear interpolation, held at the first sample before the start."""
    return jnp.interp(time - delay, time, signal)
