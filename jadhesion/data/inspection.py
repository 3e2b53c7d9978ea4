"""What a recording holds before any fit: sampling (duration, rate, jitter, gaps), ranges of speed,
creep, slip and μ̂ over the selected samples, the selection, and what the data can identify.

**Identifiability rules** (on the selected samples; 1st–99th percentiles of the magnitudes, so a
few noisy samples do not count):

* slip velocity below :data:`SLIP_FOR_AB` (0.5 m/s) throughout: Polach's ``A`` and ``B`` (the fall
  of the friction coefficient with slip velocity, ``μ = μ0 [(1 − A) e^{−B w} + A]``) change μ̂ by
  less than the noise over the range: "A and B will not be identified";
* the adhesion peak not passed — μ̂ (median per creep bin, :data:`CREEP_BINS` bins) highest in
  the largest-creep bin: "μ0 weakly identified" (only the rising branch is seen);
* smallest creep above :data:`CREEP_FOR_SLOPE` (0.005): the initial slope (``kA``) weakly
  identified;
* fewer than :data:`FEW_SAMPLES` samples selected: the standard errors will be rough;
* the vehicle speed within a factor :data:`SPEED_SPAN` (:func:`single_speed`): slip velocity and
  creep proportional, A and B traded against the creep shape (kA, kS, μ0);
* μ̂ above :data:`MU_IMPLAUSIBLE` at its 95th percentile (:func:`implausible_adhesion`): no
  wheel–rail contact transmits that (dry rail peaks near 0.4–0.5, sanded near 0.6), so the torque's
  unit or place (wheelset, not motor) or the vehicle's axle load or wheel radius is wrong.

And, from the selection, most moving samples excluded because the creep is against the drive
(:func:`jadhesion.data.selected.creep_sign_warning`): swapped speed columns or an inverted sign.
"""

from __future__ import annotations

import numpy as np

from .segments import Selection
from .selected import creep_sign_warning, stuck_speed_warning, zero_creep_message

SLIP_FOR_AB = 0.5
CREEP_FOR_SLOPE = 0.005
CREEP_BINS = 8
FEW_SAMPLES = 200
#: A 95th percentile of |μ̂| above this is no wheel–rail adhesion (:func:`implausible_adhesion`).
MU_IMPLAUSIBLE = 0.8
#: A 99th-to-1st percentile ratio of the samples' |vehicle speed| below this is one speed
#: (:func:`single_speed`): a rig's or a held run's. Our simulator's starts span 1.49, the independent
#: generator's steady runs 1.37–2.5, the kinematic generator's mainline runs 1.49 and its sweeps 1.0.
SPEED_SPAN = 1.1


def single_speed(speed):
    """``{code: "single_speed", message}`` when the samples' |vehicle speed| [m/s] spans less than a
    factor :data:`SPEED_SPAN` (1st to 99th percentile), else None: slip velocity and creep are then
    proportional, so Polach's slip-velocity factor (A, B) trades against the creep shape (kA, kS,
    μ0) along a curved valley that linear errors do not follow (on 12 constant-speed creep sweeps of
    the kinematic generator the fit's 90 % intervals held kS 8 and μ0 7 times; mainline runs at
    20 → 30 m/s 11 and 11: ``benchmarks/results/coverage_fit_kinematic.json``; the posterior's
    90 % intervals on one such sweep held kA, kS and μ0, kS's [0, 1] and μ0's [0.09, 0.71])."""
    speed = np.abs(np.asarray(speed, dtype=np.float64))
    lo, hi = np.percentile(speed, [1, 99]) if speed.size else (0.0, 0.0)
    if not hi < SPEED_SPAN * lo:
        return None
    return {
        "code": "single_speed",
        "message": (
            f"the vehicle speed stays within {lo:.4g}–{hi:.4g} m/s (1st–99th percentile, less than a "
            f"factor {SPEED_SPAN:g}): slip velocity and creep are proportional, so the curve's "
            "slip-velocity factor (A, B) trades against its creep shape (kA, kS, mu0) and their "
            "intervals can fall short (posterior samples that trade-off); runs over a range of speeds "
            "separate them"
        ),
    }


def sampling(time) -> dict:
    """``duration_s``, ``rate_hz`` (1 / median step), ``step_s`` {median, min, max} and ``jitter``
    (standard deviation of the steps within 5× the median, over the median) of sample times [s]."""
    time = np.asarray(time, dtype=np.float64)
    if time.size < 2:
        return {"duration_s": 0.0, "rate_hz": None, "step_s": None, "jitter": None}
    dt = np.diff(time)
    med = float(np.median(dt))
    regular = dt[dt <= 5.0 * med]
    return {
        "duration_s": float(time[-1] - time[0]),
        "rate_hz": 1.0 / med,
        "step_s": {"median": med, "min": float(dt.min()), "max": float(dt.max())},
        "jitter": float(np.std(regular) / med),
    }


def _range(x) -> list | None:
    x = np.asarray(x, dtype=np.float64)
    return [float(x.min()), float(x.max())] if x.size else None


def implausible_adhesion(adhesion) -> dict | None:
    """``{code: "implausible_adhesion", message}`` when the 95th percentile of ``|adhesion|`` (μ̂
    of the selected samples) exceeds :data:`MU_IMPLAUSIBLE`, else ``None``."""
    mu = np.abs(np.asarray(adhesion, dtype=np.float64))
    if mu.size == 0:
        return None
    p95 = float(np.percentile(mu, 95))
    if not p95 > MU_IMPLAUSIBLE:
        return None
    return {
        "code": "implausible_adhesion",
        "message": f"μ̂ reaches {p95:.3g} (95th percentile), beyond any wheel–rail adhesion "
        f"(> {MU_IMPLAUSIBLE:g}): check traction_torque's unit and that it is the wheelset's, not "
        "the motor's, and the vehicle's axle_load_kg and wheel_radius_m (sidecar)",
    }


def identifiability(creep, slip, adhesion, vehicle_speed=None) -> list:
    """Remarks ``{code, message}`` on what the selected samples can identify (module docstring;
    ``single_speed`` only with their ``vehicle_speed`` [m/s])."""
    creep, slip, mu = (np.abs(np.asarray(a, dtype=np.float64)) for a in (creep, slip, adhesion))
    notes = []
    if creep.size < FEW_SAMPLES:
        message = (
            f"only {creep.size} samples selected (fewer than {FEW_SAMPLES}): standard errors will be rough"
            if creep.size
            else "no sample selected: nothing to identify (the selection says what was excluded; "
            "another --phase, --start or --end?)"
        )
        notes.append({"code": "few_samples", "message": message})
    if creep.size == 0:
        return notes
    if (note := implausible_adhesion(mu)) is not None:
        notes.append(note)
    if vehicle_speed is not None and (note := single_speed(vehicle_speed)) is not None:
        notes.append(note)
    w_hi = float(np.percentile(slip, 99))
    if w_hi < SLIP_FOR_AB:
        notes.append(
            {
                "code": "slip_range",
                "message": f"slip velocity never exceeds "
                f"{SLIP_FOR_AB:g} m/s (99th percentile {w_hi:.3g} m/s): A and B will not be "
                f"identified",
            }
        )
    edges = np.quantile(creep, np.linspace(0.0, 1.0, CREEP_BINS + 1))
    which = np.clip(np.searchsorted(edges, creep, side="right") - 1, 0, CREEP_BINS - 1)
    medians = [np.median(mu[which == k]) if np.any(which == k) else -np.inf for k in range(CREEP_BINS)]
    if int(np.argmax(medians)) == CREEP_BINS - 1:
        notes.append(
            {
                "code": "no_peak",
                "message": f"creep never passes the adhesion peak (μ̂ "
                f"still rising at creep {float(np.percentile(creep, 99)):.3g}): μ0 weakly "
                f"identified, the falling branch not seen",
            }
        )
    s_lo = float(np.percentile(creep, 1))
    if s_lo > CREEP_FOR_SLOPE:
        notes.append(
            {
                "code": "no_small_creep",
                "message": f"creep never below {s_lo:.3g} (1st "
                f"percentile): the initial slope (kA) weakly identified",
            }
        )
    return notes


def inspect_document(recording, selection: Selection, dataset) -> dict:
    """The inspection of ``recording`` as JSON: ``file``, ``samples``, ``columns``, ``sources``,
    ``notes``, ``sampling`` (:func:`sampling`, with ``gaps``), ``ranges`` of the selected samples
    (``vehicle_speed`` [m/s], ``creep`` [-], ``slip_velocity`` [m/s], ``adhesion`` μ̂ [-]) and
    ``ranges_all`` of every sample's speeds, ``selection`` and ``identifiability`` (the
    selection's ``creep_sign`` remark first, where it applies; ``zero_creep`` alone where the
    recorded creep is 0 on every selected sample, which the identifying commands refuse)."""
    cols = recording.columns
    timing = (
        sampling(cols["time"])
        if "time" in cols
        else {"duration_s": None, "rate_hz": None, "step_s": None, "jitter": None}
    )
    timing["gaps"] = [list(g) for g in selection.gaps]
    ranges = {
        "vehicle_speed": _range(dataset.vehicle_speed),
        "creep": _range(dataset.creep),
        "slip_velocity": _range(dataset.slip),
        "adhesion": _range(dataset.adhesion),
    }
    every = {c: _range(cols[c]) for c in ("vehicle_speed", "wheel_speed", "traction_torque") if c in cols}
    sign = creep_sign_warning(recording, selection)
    stuck = stuck_speed_warning(recording)
    zero = zero_creep_message(recording, selection.mask) if selection.used else None
    remarks = (
        [{"code": "zero_creep", "message": zero}]  # fit, posterior and online refuse it
        if zero is not None
        else identifiability(dataset.creep, dataset.slip, dataset.adhesion, dataset.vehicle_speed)
    )
    return {
        "file": str(recording.path),
        "samples": recording.n_samples,
        "columns": sorted(cols),
        "sources": dict(recording.sources),
        "notes": list(recording.notes),
        "sampling": timing,
        "ranges": ranges,
        "ranges_all": every,
        "selection": selection.document(),
        "identifiability": [
            {"code": w["code"], "message": w["message"]} for w in (sign, stuck) if w is not None
        ]
        + remarks,
    }
