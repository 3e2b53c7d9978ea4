"""The fitting dataset: what an identification sees (the observer's output, or a creepage file)."""

from __future__ import annotations

from typing import NamedTuple

import jax


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
