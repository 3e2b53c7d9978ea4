"""The fitting dataset of the samples :func:`jadhesion.data.segments.select` keeps.

The observer and the creep smoother run on each stretch between gaps alone (a time series filter
must never bridge a gap); only then is the selection mask applied, so every selected sample has
its full observer history within its stretch. With every sample selected in one stretch the
result is exactly :func:`jadhesion.data.dataset.to_dataset` of the recording.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..errors import RecordingError
from ..models.effects import on_clock
from .dataset import PolachDataset, adhesion_source, to_dataset
from .segments import (
    MIN_DRIVE_MU,
    MIN_SPEED,
    MIN_STRETCH_SAMPLES,
    Selection,
    longest_run,
    raw_creep,
    select,
    slice_recording,
)
from .validate import MAX_ADHESION

#: More than this share of the moving samples with the creep against the drive: a recording error.
DISAGREE_SHARE = 0.5


def _concatenate(parts) -> PolachDataset:
    first = parts[0]
    fields = {}
    for name in PolachDataset._fields:
        if name == "k_eps":
            fields[name] = first.k_eps
        elif any(getattr(p, name) is None for p in parts):  # e.g. a short stretch's raw creep
            fields[name] = None
        else:
            fields[name] = jnp.concatenate([getattr(p, name) for p in parts])
    return PolachDataset(**fields)


def _weak_drive_hint(recording) -> str:
    """Where every moving sample counts as coasting: the largest drive, and what to check (a torque
    in kN·m read as N·m, or at the motor, or a wrong vehicle, all look like coasting)."""
    cols = recording.columns
    if "traction_torque" not in cols:
        return ""
    moving = np.abs(np.asarray(cols["vehicle_speed"], float)) >= MIN_SPEED
    if not moving.any():
        return ""
    veh = recording.vehicle
    drive = float(np.max(np.abs(cols["traction_torque"][moving]))) / (veh.axle_weight_n * veh.wheel_radius_m)
    if not 0.0 < drive < MIN_DRIVE_MU:  # no torque at all is plain coasting
        return ""
    return (
        f"; the largest torque is {drive:.3g} of the axle weight × wheel radius (coasting below "
        f"{MIN_DRIVE_MU:g}): check traction_torque's unit (N·m at the wheelset) and axle_load_kg, "
        "wheel_radius_m"
    )


def creep_sign_warning(recording, selection: Selection) -> dict | None:
    """``{code: "creep_sign", params: [], message}`` when more than :data:`DISAGREE_SHARE` of the
    moving samples (``|v| >= MIN_SPEED``) are excluded because the creep has the drive's opposite
    sign ("torque and creep disagree"), else ``None``. No adhesion law does that to most of a run:
    the recording is the likely cause, and the message names what to check (swapped speed columns,
    an inverted sign), with the share of the wheel slower than the vehicle under traction and
    faster under braking."""
    cols = recording.columns
    v = np.asarray(cols["vehicle_speed"], float)
    moving = np.abs(v) >= MIN_SPEED
    disagree = selection.labels == "torque and creep disagree"
    n = int(moving.sum())
    if n == 0 or not disagree.sum() > DISAGREE_SHARE * n:
        return None
    slower = np.where(v < 0, -1.0, 1.0) * raw_creep(cols, v) < 0  # in the direction of travel
    shares = (
        ("wheel slower than vehicle under traction", np.sum(disagree & slower) / n),
        ("wheel faster than vehicle under braking", np.sum(disagree & ~slower) / n),
    )
    what = " and ".join(f"{text} on {100 * share:.0f} %" for text, share in shares if share >= 0.01)
    drive = "the torque's" if "traction_torque" in cols else "the adhesion's"
    if "wheel_speed" in cols and not {"creepage", "slip_velocity"} & set(cols):
        check = f"are wheel_speed and vehicle_speed swapped, or {drive} sign inverted?"
    else:
        source = "creepage" if "creepage" in cols else "slip_velocity"
        check = f"is {source}'s sign inverted, or {drive}?"
    return {"code": "creep_sign", "params": [], "message": f"{what} of moving samples: {check}"}


#: A speed that holds one exact value this long [s] while the other speed moves is stuck or clipped.
STUCK_S = 2.0
#: ... moves: by more than this [m/s], and by more than two of its own steps (a coarse quantum).
STUCK_PARTNER_CHANGE = 0.2


def _longest_hold(values, mask) -> tuple[int, int]:
    """``(first, last)`` sample indices of the longest run of consecutive ``mask`` samples holding
    one exact value; ``(0, 0)`` when none holds for two samples."""
    run = longest_run((np.diff(values) == 0) & mask[1:] & mask[:-1])  # run over pairs i, i + 1
    return (0, 0) if run is None else run


def stuck_speed_warning(recording) -> dict | None:
    """``{code: "stuck_signal", params: [], message}`` when a speed column holds one exact value
    for :data:`STUCK_S` or longer while moving (either speed at least ``MIN_SPEED``; not the
    selection: the samples a stuck speed puts against the drive are excluded from it) while the
    other speed changes by more than :data:`STUCK_PARTNER_CHANGE` and two of its steps: a stuck or
    clipped sensor (a wheel speed clipped for 12.9 s gave a 'converged' fit whose 95 % interval of
    mu_max missed the truth), with where; the longest such hold, ``None`` without one (or without
    a time column)."""
    cols = recording.columns
    if "time" not in cols or not {"wheel_speed", "vehicle_speed"} <= set(cols):
        return None
    t = np.asarray(cols["time"], float)
    moving = np.maximum(np.abs(cols["vehicle_speed"]), np.abs(cols["wheel_speed"])) >= MIN_SPEED
    found = []
    for col, other in (("wheel_speed", "vehicle_speed"), ("vehicle_speed", "wheel_speed")):
        x, y = np.asarray(cols[col], float), np.asarray(cols[other], float)
        i, j = _longest_hold(x, moving)
        if t[j] - t[i] < STUCK_S:
            continue
        steps = np.abs(np.diff(y))
        quantum = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.0
        change = float(np.ptp(y[i : j + 1]))
        if change > max(STUCK_PARTNER_CHANGE, 2.0 * quantum):
            found.append((t[j] - t[i], col, other, x[i], change, i, j, abs(x[i]) == np.max(np.abs(x))))
    if not found:
        return None
    held, col, other, value, change, i, j, at_max = max(found)
    return {
        "code": "stuck_signal",
        "params": [],
        "message": f"{col} holds {value:.6g} m/s exactly for {held:.3g} s ({on_clock((t[i], t[j]), t[0])})"
        f"{' at its largest value' if at_max else ''} while {other} changes by {change:.3g} m/s: a "
        "stuck or clipped sensor? leave the stretch out with --start/--end",
    }


def no_samples_message(recording, selection: Selection) -> str:
    """One line: the phase selected nothing, what the samples were, and where no moving sample
    has a drive, or most have the creep against it (:func:`creep_sign_warning`), what to check."""
    counts = ", ".join(f"{k} {v}" for k, v in sorted(selection.counts().items()))
    sign = creep_sign_warning(recording, selection)
    return (
        f"{recording.path}: --phase {selection.phase} selects no samples ({counts}); try "
        f"another --phase or --start/--end{_weak_drive_hint(recording)}"
        + ("" if sign is None else f"; {sign['message']}")
    )


#: |creep| [-] below which a recorded creep counts as 0 (no sensor resolves 1e-12; a creep of
#: 1e-310 had been fitted, every parameter "at_bound").
ZERO_CREEP = 1e-12


def zero_creep_message(recording, mask) -> str | None:
    """One line when the recorded creep is 0 (below :data:`ZERO_CREEP`) on every sample of
    ``mask`` (bool (n,), the samples used: nothing to identify; typically a vehicle speed computed
    from this wheel's own speed), else ``None``."""
    cols = recording.columns
    v = np.asarray(cols["vehicle_speed"], float)
    if np.any(np.abs(raw_creep(cols, v)[mask]) >= ZERO_CREEP):
        return None
    source = next((c for c in ("creepage", "slip_velocity") if c in cols), "wheel_speed − vehicle_speed")
    return (
        f"{recording.path}: the creep ({source}) is 0 (|creep| < {ZERO_CREEP:g}) on all "
        f"{int(np.sum(mask))} selected samples: nothing to identify "
        "(is vehicle_speed computed from this wheel's own speed?)"
    )


def require_plausible_mu_hat(recording, adhesion) -> None:
    """Raise :class:`RecordingError` when the observer's μ̂ on the samples used (``adhesion``) has a
    median |μ̂| above :data:`.validate.MAX_ADHESION` (or not finite), as an ``adhesion`` column
    with such a value is refused: the torque's unit or the sidecar's axle load, radius or wheelset
    inertia is wrong (an inertia of 1e300 gave μ̂ ~ 1e293, a 'converged' LM fit of MAE 1e293 and
    a NaN traceback from the population methods)."""
    if adhesion_source(recording) != "observer":  # a column: checked as it was read
        return
    mu = np.abs(np.asarray(adhesion, float))
    median = float(np.median(mu)) if mu.size else 0.0
    if not median <= MAX_ADHESION:
        raise RecordingError(
            f"{recording.path}: the observer's adhesion estimate mu_hat has median |mu_hat| "
            f"{median:.3g} on the selected samples, implausible (<= {MAX_ADHESION:g}): check "
            "traction_torque's unit and the sidecar's axle_load_kg, wheel_radius_m and "
            "wheelset_inertia_kgm2"
        )


def usable_selection(recording, phase: str) -> Selection:
    """:func:`.segments.select` of ``phase``, refused when it holds nothing to identify.

    Raises:
        RecordingError: no sample selected (:func:`no_samples_message`), or the creep is exactly
            0 on every selected sample (:func:`zero_creep_message`).
    """
    selection = select(recording, phase)
    if selection.used == 0:
        raise RecordingError(no_samples_message(recording, selection))
    if (message := zero_creep_message(recording, selection.mask)) is not None:
        raise RecordingError(message)
    return selection


def per_stretch_dataset(
    recording, selection: Selection, observer_variant: str = "paper", creep: str = "raw", *, build=to_dataset
) -> PolachDataset:
    """The dataset of every sample (none masked), the observer run on each stretch alone (default
    ``creep="raw"``; a stretch shorter than ``MIN_STRETCH_SAMPLES`` always raw); for inspection,
    figures and :func:`tracking_dataset`."""
    parts = [
        build(
            slice_recording(recording, slice(a, b)),
            observer_variant,
            creep if b - a >= MIN_STRETCH_SAMPLES else "raw",  # too short for the smoother
        )
        for a, b in selection.stretches
    ]
    return parts[0] if len(parts) == 1 else _concatenate(parts)


def tracking_dataset(recording, phase: str = "traction", creep: str = "smoothed", *, build=to_dataset):
    """``(PolachDataset, Selection)`` for a sample-by-sample tracker: every sample in time order
    (the observer and smoother per stretch, :func:`per_stretch_dataset`), ``weight`` 1 on the
    samples of ``phase`` and 0 elsewhere (the tracker holds its estimate there), and creep, slip
    and μ̂ oriented by the direction of travel and, on braking samples, the drive's sign: braking
    and running backwards read as traction (``sign(v)`` × −1 on braking samples, else × +1).

    Raises:
        RecordingError: as :func:`usable_selection`, or an implausible μ̂
            (:func:`require_plausible_mu_hat`).
    """
    selection = usable_selection(recording, phase)
    data = per_stretch_dataset(recording, selection, creep=creep, build=build)
    require_plausible_mu_hat(recording, np.asarray(data.adhesion)[selection.mask])
    v = np.asarray(recording.columns["vehicle_speed"], float)
    braking = np.where(selection.labels == "braking", -1.0, 1.0)
    orient = jnp.asarray(np.where(v < 0, -1.0, 1.0) * braking)
    return (
        data._replace(
            creep=orient * data.creep,
            slip=orient * data.slip,
            adhesion=orient * data.adhesion,
            weight=jnp.asarray(selection.mask, dtype=data.adhesion.dtype),
        ),
        selection,
    )


def selected_dataset(
    recording,
    phase: str = "traction",
    observer_variant: str = "paper",
    creep: str = "smoothed",
    *,
    build=to_dataset,
):
    """``(PolachDataset, Selection)``: the dataset of the samples of ``phase``.

    ``build(recording, observer_variant, creep)`` makes one stretch's dataset (default
    :func:`~jadhesion.data.dataset.to_dataset`; the CLI passes its cached drop-in).

    Raises:
        RecordingError: as :func:`usable_selection`, or an implausible μ̂
            (:func:`require_plausible_mu_hat`).
    """
    selection = usable_selection(recording, phase)
    if selection.mask.size < MIN_STRETCH_SAMPLES:  # too short for the smoother: the raw
        creep = "raw"  # difference (the fit names its minimum)
    if selection.complete:
        data = build(recording, observer_variant, creep)
        require_plausible_mu_hat(recording, data.adhesion)
        return data, selection
    parts = []
    for a, b in selection.stretches:
        keep = selection.mask[a:b]
        if not keep.any():
            continue
        data = build(slice_recording(recording, slice(a, b)), observer_variant, creep)
        parts.append(
            type(data)(
                *(
                    f if f is None or name == "k_eps" else f[keep]
                    for name, f in zip(PolachDataset._fields, data, strict=True)
                )
            )
        )
    data = _concatenate(parts)
    require_plausible_mu_hat(recording, data.adhesion)
    return data, selection
