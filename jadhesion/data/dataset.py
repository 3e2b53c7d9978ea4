"""The fitting dataset: what an identification sees (the observer's output, or a creepage file).

:func:`to_dataset` is the observer stage of the data flow: recording → observer → dataset. With
the raw signals it estimates creep and slip as states (:mod:`.creep_state`, ``creep="smoothed"``,
the default) and carries their standard deviations; ``creep="raw"`` keeps the plain difference of
the recorded speeds.

**The adhesion column (one rule, applied here by :func:`adhesion_source`).** When the four raw
signals (``time``, ``vehicle_speed``, ``wheel_speed``, ``traction_torque``) are present, ``mu_hat``
is always the observer's output and an ``adhesion`` column is ignored (the CLI's loading adds a
note); only a fitting-dataset file without them supplies ``mu_hat`` through ``adhesion``. (Checked
on simulated recordings, whose ``adhesion`` column is the observer's output: the datasets differ
by < 2e-15.)

**Default: smoothed.** On simulated 22E recordings (2 000 samples) with realistic sensors (1e-3
m/s white + 5e-4 m/s AR(1) + 1 mm/s quantisation per speed) the smoothed creep's RMS error is 2.4×
(dry) and 1.8× (sand) smaller than the raw difference's; on the historical clean sensors (5e-5
m/s) 1.7× and 1.3× smaller, with calibrated standard deviations (``tests/test_creep_state.py``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..models import kinematics
from .creep_state import coasting_sd_scale, smooth_recording
from .length_buckets import bucket_length
from .observer import observe_adhesion

if TYPE_CHECKING:
    from .recording import Recording


class PolachDataset(NamedTuple):
    """Samples of the adhesion curve, one per row; a pytree, so batches of datasets vmap.

    Attributes:
        creep: creepage s [-], shape (n,).
        slip: slip velocity w [m/s], shape (n,).
        adhesion: observed adhesion coefficient mu_hat [-], shape (n,).
        vehicle_speed: v [m/s], shape (n,).
        k_eps: Polach gradient constant [-] of the vehicle's contact, shape ().
        slip_sd: standard deviation of ``slip`` [m/s], shape (n,), or None (exact / unknown).
        creep_sd: standard deviation of ``creep`` [-], shape (n,), or None.
        weight: per-sample mask (n,) — 1 for a sample, 0 for padding — or None (every sample
            counts; results bit-identical to a dataset without the field). Set by
            :func:`jadhesion.identify.batch_fit.pad_dataset` to fit datasets of different lengths
            with one compiled program.
        residual_scale: robust sd [-] of ``mu_hat`` about the curve, shape (), or None. Set by
            LM's first stage (:func:`jadhesion.identify.polach_fit.fit_polach`); with it LM's
            residual is standardised and robust
            (:func:`jadhesion.identify.polach_residuals.polach_lm_residual`).
        node_slips: the true slip [m/s] at each node of the errors-in-variables expectation,
            shape (n, nodes), or None (computed from ``slip``, ``slip_sd`` and ``adhesion`` where
            needed). A function of the data alone, set once by
            :func:`jadhesion.identify.likelihood.with_node_slips` where a fit or a sampler starts,
            so that its residual does not evaluate the nodes' inverse normal CDFs at every step.
        slip_sd_scale: the factor [-] ``slip_sd`` and ``creep_sd`` were scaled by, per sample
            (one per stretch the smoother ran on: :func:`jadhesion.data.creep_state.coasting_sd_scale`,
            1 without enough coasting), shape (n,), or None (no smoother).
    """

    creep: jax.Array
    slip: jax.Array
    adhesion: jax.Array
    vehicle_speed: jax.Array
    k_eps: jax.Array
    slip_sd: Optional[jax.Array] = None
    creep_sd: Optional[jax.Array] = None
    weight: Optional[jax.Array] = None
    residual_scale: Optional[jax.Array] = None
    node_slips: Optional[jax.Array] = None
    slip_sd_scale: Optional[jax.Array] = None


#: Fields with one row per sample (axis 0); ``k_eps`` is one per dataset, ``weight`` the padding's
#: mask.
SAMPLE_FIELDS = (
    "creep",
    "slip",
    "adhesion",
    "vehicle_speed",
    "slip_sd",
    "creep_sd",
    "node_slips",
    "slip_sd_scale",
)

CREEP_OPTIONS = ("smoothed", "raw")
RAW_SIGNALS = ("time", "vehicle_speed", "wheel_speed", "traction_torque")


class Signals(NamedTuple):
    """What :func:`to_dataset` reads of a recording with the raw signals: ``columns`` (a dict
    holding :data:`RAW_SIGNALS`) and ``vehicle`` (anything with the vehicle's numbers)."""

    columns: dict
    vehicle: object


def padded_signals(columns, length: int) -> tuple[dict, np.ndarray]:
    """``(columns, valid)``: the :data:`RAW_SIGNALS` of ``columns`` padded to ``length`` rows by
    repeating the last row (time too: zero steps) and the (length,) mask of the real rows (1/0)."""
    n = len(columns["time"])
    padded = {c: np.pad(np.asarray(columns[c]), (0, length - n), mode="edge") for c in RAW_SIGNALS}
    valid = np.zeros(length)
    valid[:n] = 1.0
    return padded, valid


def to_dataset(
    recording: "Recording",
    observer_variant: str = "paper",
    creep: str = "smoothed",
    *,
    k_eps: float | None = None,
    pad: bool = True,
    valid=None,
) -> PolachDataset:
    """The fitting dataset (creep s, slip w, mu_hat, v, k_eps; with ``creep="smoothed"`` also
    ``slip_sd``, ``creep_sd``) of a recording (or a simulation result).

    ``creep="smoothed"`` (default): when the recording has the four raw signals (``time``, both
    speeds, ``traction_torque``), slip, creep and vehicle speed are the RTS-smoothed states of
    :func:`jadhesion.data.creep_state.smooth_recording`, their standard deviations scaled by
    :func:`jadhesion.data.creep_state.coasting_sd_scale` (1 without coasting); ``mu_hat`` stays
    the observer's. Without
    raw signals, or with ``creep="raw"``, as follows.

    Without the raw signals the ``adhesion`` column is used directly: creepage from ``creepage``, else from
    ``slip_velocity`` (or ``wheel_speed − vehicle_speed``) through
    :func:`jadhesion.models.kinematics.creepage`; the slip velocity from ``slip_velocity``, else
    ``creepage · max(|v|, floor)`` (the inverse of that creepage). With them, the adhesion observer
    (:func:`jadhesion.data.observer.observe_adhesion`, ``observer_variant``) runs on the raw
    signals and creep comes from the wheel and vehicle speeds. ``k_eps``: the vehicle's gradient
    constant when already known (default ``recording.vehicle.k_eps()``).

    ``pad`` (default): the raw signals go through the observer and the smoother padded to their
    length bucket (:func:`jadhesion.data.length_buckets.bucket_length`; the last row repeated) and
    the dataset is cut back to the recording's rows: the same values bit for bit, one compiled
    program per bucket instead of one per length. ``valid``: the columns are padded already; their
    (n,) mask of real rows (1/0, padding only at the end), and the dataset keeps the padded length.
    """
    if creep not in CREEP_OPTIONS:
        raise ValueError(f"creep must be one of {CREEP_OPTIONS}, got {creep!r}")
    raw_signals = adhesion_source(recording) == "observer"
    time = recording.columns["time"] if raw_signals else None
    if pad and valid is None and raw_signals and not isinstance(time, jax.core.Tracer):
        n = len(time)
        if bucket_length(n) > n:
            columns, valid = padded_signals(recording.columns, bucket_length(n))
            data = to_dataset(
                Signals(columns, recording.vehicle), observer_variant, creep, k_eps=k_eps, valid=valid
            )
            return cut(data, n)
    raw = _raw_dataset(recording, observer_variant, k_eps)
    if creep == "raw" or not raw_signals:
        return raw
    est = smooth_recording(recording, valid)
    scale, _ = coasting_sd_scale(est.slip, est.slip_sd, raw.adhesion, est.vehicle_speed, valid)
    return raw._replace(
        creep=est.creep,
        slip=est.slip,
        vehicle_speed=est.vehicle_speed,
        slip_sd=scale * est.slip_sd,
        creep_sd=scale * est.creep_sd,
        slip_sd_scale=jnp.full_like(est.slip_sd, scale),
    )


def _rows(data: PolachDataset, rows: slice) -> PolachDataset:
    """The dataset's ``rows``, sliced on the host (no program per length); NumPy fields stay NumPy,
    JAX ones JAX."""

    def take(a):
        return a[rows] if isinstance(a, np.ndarray) else jnp.asarray(np.asarray(a)[rows])

    return data._replace(**{f: take(getattr(data, f)) for f in SAMPLE_FIELDS if getattr(data, f) is not None})


def cut(data: PolachDataset, n: int) -> PolachDataset:
    """The first ``n`` rows of a dataset (:func:`_rows`)."""
    return _rows(data, slice(n))


def thinned(data: PolachDataset, every: int) -> PolachDataset:
    """Every ``every``-th row of a dataset (rows 0, every, 2·every, …; :func:`_rows`)."""
    return _rows(data, slice(None, None, every))


def adhesion_source(recording) -> str:
    """``"observer"`` when the recording has the raw signals (an ``adhesion`` column is then
    ignored), else ``"column"``: the module docstring's one rule for an ``adhesion`` column."""
    return "observer" if all(c in recording.columns for c in RAW_SIGNALS) else "column"


def _raw_dataset(recording, observer_variant: str, k_eps=None) -> PolachDataset:
    cols = recording.columns
    v = cols["vehicle_speed"]
    if adhesion_source(recording) == "column":
        v = np.asarray(v)
        mu = np.asarray(cols["adhesion"])
        if "slip_velocity" in cols:
            w = np.asarray(cols["slip_velocity"])
        elif "creepage" not in cols:
            w = np.asarray(kinematics.slip_velocity(cols["wheel_speed"], v))
        if "creepage" in cols:
            s = np.asarray(cols["creepage"])
            if "slip_velocity" not in cols:
                w = s * np.maximum(np.abs(v), kinematics.SPEED_FLOOR)
        else:
            s = np.asarray(kinematics.creepage(w, v))
    else:
        mu = observe_adhesion(
            cols["time"], cols["wheel_speed"], cols["traction_torque"], recording.vehicle, observer_variant
        )
        w = kinematics.slip_velocity(cols["wheel_speed"], v)  # traceable: the CLI keeps it as a program
        s = kinematics.creepage(w, v)
    if k_eps is None:
        k_eps = recording.vehicle.k_eps()
    return PolachDataset(
        creep=jnp.asarray(s),
        slip=jnp.asarray(w),
        adhesion=jnp.asarray(mu),
        vehicle_speed=jnp.asarray(v),
        k_eps=jnp.asarray(k_eps),
    )


def valid_mask(data: PolachDataset) -> np.ndarray:
    """(n,) bool: the samples that count — all of them, or the mask's ones (not the padding)."""
    if data.weight is None:
        return np.ones(data.adhesion.shape[-1], bool)
    return np.asarray(data.weight) > 0


def sd_scale_summary(data: PolachDataset) -> dict | None:
    """The JSON's ``slip_sd_scale``: ``{min, median, max}`` [-] over the dataset's samples (the
    padding left out) of the factor the smoother's sds were scaled by where the recording coasts
    (1: not scaled: fewer than 50 coasting samples, or the smoother's sd not short), or ``None``
    without a smoother (raw creep, a creepage file)."""
    if data.slip_sd_scale is None:
        return None
    scale = np.asarray(data.slip_sd_scale, float)[valid_mask(data)]
    return {"min": float(scale.min()), "median": float(np.median(scale)), "max": float(scale.max())}
