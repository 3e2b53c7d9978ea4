"""The fitting dataset: what an identification sees (the observer's output, or a creepage file).

:func:`to_dataset` is the observer stage of the data flow: recording → observer → dataset.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..models import kinematics
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
    """

    creep: jax.Array
    slip: jax.Array
    adhesion: jax.Array
    vehicle_speed: jax.Array
    k_eps: jax.Array


def to_dataset(recording: "Recording", observer_variant: str = "paper", *,
               k_eps: float | None = None) -> PolachDataset:
    """The fitting dataset (creep s, slip w, mu_hat, v, k_eps) of a recording.

    With an ``adhesion`` column it is used directly: creepage from ``creepage``, else from
    ``slip_velocity`` (or ``wheel_speed − vehicle_speed``) through
    :func:`jadhesion.models.kinematics.creepage`; the slip velocity from ``slip_velocity``, else
    ``creepage · max(|v|, floor)`` (the inverse of that creepage). Without it, the adhesion observer
    (:func:`jadhesion.data.observer.observe_adhesion`, ``observer_variant``) runs on the raw
    signals and creep comes from the wheel and vehicle speeds. ``k_eps``: the vehicle's gradient
    constant when already known (default ``recording.vehicle.k_eps()``).
    """
    cols = recording.columns
    v = np.asarray(cols["vehicle_speed"])
    if recording.has_adhesion:
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
        mu = observe_adhesion(cols["time"], cols["wheel_speed"], cols["traction_torque"],
                              recording.vehicle, observer_variant)
        w = np.asarray(kinematics.slip_velocity(cols["wheel_speed"], v))
        s = np.asarray(kinematics.creepage(w, v))
    if k_eps is None:
        k_eps = recording.vehicle.k_eps()
    return PolachDataset(creep=jnp.asarray(s), slip=jnp.asarray(w), adhesion=jnp.asarray(mu),
                         vehicle_speed=jnp.asarray(v), k_eps=jnp.asarray(k_eps))
