"""What a recording can see: the smallest magnitude of each catalogue effect it could detect.

An effect whose signature the Polach parameters can mimic is invisible however large it is (a torque
offset on a saturated curve; load transfer, whose ``L = 1 − m_L F_t/(M g)`` follows μ itself on a
quasi-steady pull). :func:`detectable_magnitudes` says so per recording instead of leaving a
``"none"`` verdict to be read as "absent".

Linearised at the final fit (the base model, or the base model with the accepted effects): an
effect of magnitude ``m`` changes the residual by ``m j`` with ``j = ∂r/∂m`` at its neutral value.
The fitted model absorbs the part of ``j`` in the span of its own Jacobian ``J`` (the five Polach
columns and those of the other accepted effects); the rest, ``q = ‖(I − P_J) j‖``, is what the data
can tell apart. Modelling the effect lowers the sum of squares by about ``m² q²`` and the mean
absolute error by the fraction ``m² q² / (2 SSE)`` (MAE ∝ RMS for a fixed residual shape). The
decision accepts an effect from a held-out gain of :data:`~.select.GAIN_THRESHOLD` = ``G``, so
this recording detects magnitudes above

    m_min = √(2 G SSE) / q,

or, when the recording's null gave the critical in-sample SSE reduction ``T*`` (the 95th
percentile of the replicas' largest, :mod:`.null`) and it is the stricter of the decision's two
conditions, above ``m_min = √(T* SSE) / q``.

and ``absorbed = 1 − q²/‖j − j̄‖²`` says how much of the signature the model takes up. The
linearisation ignores the box (a Polach parameter on its bound absorbs less), held-out losses (a
little more is needed in practice) and curvature (large magnitudes of load transfer are not
linear). The blind benchmark compares ``m_min`` with what was detected
(``benchmarks/diagnose_blind.py --n 200 --null 0 --seed 23``, single effects): named in 59 of 62
cases above their recording's own limit and 11 of 66 below it, signal delay apart. For a signal
delay the limit is optimistic (named in 2 of 12 cases above it; the delays named were ≥ 0.14 s
against limits near 0.05 s): the extension's first-order re-alignment ``τ·dT/dt`` of the smoothed
torque captures only part of a true shift.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from . import extensions as ext
from .select import GAIN_THRESHOLD


@jax.jit
def linearise(params, active, sig):
    """Residual ``target − pred`` (n,) and its Jacobian ``∂r/∂params`` (n, N_PARAMS)."""

    def residual(p):
        target, pred = ext.predict(p, active, sig)
        return target - pred, target - pred

    jac, r = jax.jacfwd(residual, has_aux=True)(params)
    return r, jac


def detectable_magnitudes(
    params, active, u_change, sig, n_valid: int, accepted=(), critical=None, threshold: float = GAIN_THRESHOLD
) -> dict:
    """Per effect: ``min_detectable`` (|magnitude| in the catalogue's units, ``inf`` when the fitted
    model absorbs the signature entirely or the size lies beyond the extension's box: a relative
    μ0 drop of 1 828 is none), ``absorbed`` (share of the signature the fitted model
    takes up), ``visible`` (``min_detectable`` within the catalogue's typical range,
    :attr:`~jadhesion.models.effect_spec.EffectSpec.typical`) and ``experiment`` (its ``exposing_run``).

    ``params`` (N_PARAMS,) and ``active`` (N_EXTRA,) are the final fit, ``accepted`` its effects;
    ``u_change`` places the rail change's step where it is not fitted (its signature depends on
    the time); ``sig`` the recording's signals padded as for the fits
    (:func:`.fitting.pad_signals`, one compiled program per padded length), of which the first
    ``n_valid`` samples are the recording (those of weight 0 are left out); ``critical`` the null's
    critical SSE reduction (None: the held-out gain ``threshold``).
    """
    theta, extras = ext.unpack(np.asarray(params, float), np.asarray(active))
    full = np.concatenate([np.asarray(theta), np.array([float(extras[k]) for k in ext.EXTRA_NAMES])])
    if "rail_change" not in accepted:
        full[5 + ext.EXTRA_NAMES.index("u_change")] = u_change
    r, jac = linearise(jnp.asarray(full), jnp.ones(ext.N_EXTRA, bool), sig)
    keep = np.asarray(sig.weight)[:n_valid] > 0
    r, jac = np.asarray(r)[:n_valid][keep], np.asarray(jac)[:n_valid][keep]
    sse = float(np.sum(r * r))
    out = {}
    for effect in ext.EFFECTS:
        fitted = [
            5 + ext.EXTRA_NAMES.index(p)
            for e in ext.EFFECTS
            if e.name in accepted and e.name != effect.name
            for p in e.params
        ]
        model = jac[:, list(range(5)) + fitted]
        j = jac[:, 5 + ext.EXTRA_NAMES.index(effect.magnitude_param)]
        coef, *_ = np.linalg.lstsq(model, j, rcond=None)
        q2 = float(np.sum(np.square(j - model @ coef)))
        spread = float(np.sum(np.square(j - j.mean())))
        level = 2.0 * threshold if critical is None else max(2.0 * threshold, critical)
        m_min = float(np.sqrt(level * sse / q2)) if q2 > 0 else float("inf")
        box = next(p for p in effect.extension if p.name == effect.magnitude_param)
        if m_min > max(abs(box.lower), abs(box.upper)):  # beyond any size the model has: none
            m_min = float("inf")
        out[effect.name] = {
            "min_detectable": m_min,
            "absorbed": float(np.clip(1.0 - q2 / spread, 0.0, 1.0)) if spread > 0 else 1.0,
            "visible": m_min <= effect.typical[1],
            "experiment": effect.exposing_run,
        }
    return out
