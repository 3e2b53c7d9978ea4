import jax.numpy as jnp

from jadhesion import LOCO_22E, polach_adhesion


def test_polach_dry_curve_peaks_near_paper_level():
    theta = jnp.array([0.4288, 1.0, 0.3555, 0.3575, 0.1316])
    mu = polach_adhesion(theta, 0.01, 0.006, LOCO_22E.k_eps())
    assert 0.3 < float(mu) < 0.42
