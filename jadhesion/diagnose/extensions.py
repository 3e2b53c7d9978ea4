"""Identification-side extensions of the Polach model, one per catalogue effect (DESIGN §3).

Every candidate is the same *superset* model with a boolean ``active`` mask over the extra
parameters; an inactive extra is held at its neutral value, where the model is the base Polach fit
*exactly* (each effect enters as ``x·(1 − 0)``, ``x + 0`` or a zero shift). One compiled function
therefore fits the base model, every single effect and every pair, vmapped over candidates and
cross-validation folds. The model predicts the observed adhesion ``mu_hat`` [-]::

    target = mu_hat + τ · d(torque_mu)/dt                   (observer output, torque re-aligned)
    w, s   = E[v_w (1 + δ) − v], w / v                      (true rolling radius r (1 + δ))
    L      = max(1 − m_L μ_adh(s, w; k_eps) − m_A a/g, 0.1)  (load factor; F_t/(M g) = μ_adh)
    μ0(t)  = μ0 (1 − m_R σ((t − t_c)/W)) (1 − m_V (v − v̄)/v̄) / (1 + m_T P_th/P_ref)
    pred   = (1 + δ) L μ_adh(s, w; kA, kS, μ0(t), A, B; k_eps L^(−1/3)) + β

``E[·]`` is the mean of the slip's law given the smoother's slip and its sd, truncated to the sign
of the force (:func:`jadhesion.identify.slip_law.truncated_mean`; errors in variables). The
parameters, their boxes, neutral values and units, and the typical magnitudes are the effect
registry's (:data:`jadhesion.models.effects.EFFECTS`, each record's ``extension``; the first
parameter estimates the simulator's magnitude, so a recovered parameter compares directly with a
concealed one). How each enters, and its signature in the residual of the *base* fit:

* ``rail_change`` — the rail condition changes at an unknown time: μ0 drops by the fraction m_R
  (negative = recovery) at ``t_c``, fitted as ``u = (t_c − t_0)/D`` ∈ [0.02, 0.98] (a
  change inside the recording: at its very start a step would merely rescale μ0 past its bound);
  the step is a logistic of width ``W = 1 % · D`` so ``t_c`` is differentiable. Signature: the residual
  changes level at one time (a CUSUM kink).
* ``wheel_radius_error`` — true rolling radius ``r(1 + δ)``. The recorded wheel speed is
  ``ω r_nom``: the true slip is ``v_w(1 + δ) − v`` (an offset ∝ speed) and the force is
  ``T/(r(1 + δ))``, so ``mu_hat = (1 + δ) μ``. Signature: the residual against creep bends at small
  creep and grows with speed.
* ``signal_delay`` — the recorded torque lags the speed signals by τ: re-aligned
  to first order, ``T(t) ≈ T_rec(t) + τ dT_rec/dt``, with the smoothed torque rate
  (:attr:`Signals.torque_rate`). Not an interpolation of the noisy torque: a fractional shift
  averages neighbouring noise samples and would "detect" half-sample delays on clean data.
  Signature: residual ≈ −τ·d(torque_mu)/dt.
* ``speed_dependence`` — Curtius–Kniffler-like μ0 linear in speed about the mean speed v̄,
  relative slope m_V per relative speed change. Signature: residual linear in v.
* ``torque_offset`` — additive torque bias ``b = β m g r`` [N·m]. Signature:
  a constant residual; collinear with a μ0 change where the curve is saturated.
* ``thermal_softening`` — ``μ0 / (1 + m_T P_th/P_ref)``: ``P_th`` [W] is the frictional power
  ``mu_hat·m g·|w|`` through ``1/(1 + s τ_th)`` (:attr:`Signals.heat`; τ_th [s] is picked from a
  grid before the LM fit, :func:`jadhesion.diagnose.features.pick_thermal_lag`), ``P_ref`` = 10 kW.
  Signature: residual falls with recent slip power.
* ``load_transfer`` — the measured axle's load changes with the locomotive's pitch moment (DESIGN
  §3: tractive effort, visible through its acceleration). The simulator's law
  (:func:`jadhesion.models.effects.load_factor`), ``N1 = N (1 − m (F_d + (h_g/h_c)(M a + F_res))/(M
  g))``, is with ``F_d = F_t − M a − F_res`` the two terms ``N1 = N (1 − m_L F_t/(M g) − m_A a/g)``:
  ``m_L = m`` and ``m_A = m (h_g/h_c − 1)`` (the resistance's share is a constant load factor, taken
  up by μ0). ``F_t/(M g)`` is the model's own curve at the static load (all ``n`` axles at this
  axle's adhesion carry the weight, ``n N = M g``; the Hertz change of μ with the load is second
  order), not the recorded torque: a torque-based regressor shares the torque noise of ``mu_hat``
  and biases ``m_L`` (on a clean 1000-sample wet run it pulled m_L to its bound −0.3 with or without
  the effect, Δχ² = 27 against the truth). The acceleration ``a`` is :attr:`Signals.accel`. The two
  terms separate only where ``a`` varies independently of ``F_t``: with a trailing load whose pull
  changes at constant creep; without one (``F_d = 0``) ``F_t = M a + F_res`` and only
  ``m_L + m_A`` shows. The observer divides by the static load, so ``mu_hat = L μ``, and Hertz gives
  ``k_eps ∝ L^(−1/3)``. Signature: ``mu_hat ≈ μ − m_L μ²`` while the tractive effort follows this
  axle's adhesion — a change of the curve's shape that Polach's parameters largely absorb.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..data.vehicle import GRAVITY
from ..identify.slip_law import truncated_mean
from ..models.effects import EFFECTS as REGISTRY
from ..models.effects import THERMAL_POWER_SCALE as POWER_REF
from ..models.kinematics import creepage
from ..models.polach import BOUNDS as POLACH_BOUNDS
from ..models.polach import PARAM_NAMES, polach_adhesion
from .signals import Signals

#: Logistic width of the rail-change step, as a fraction of the recording's duration.
STEP_WIDTH = 0.01

#: The catalogue's records (:class:`jadhesion.models.effect_spec.EffectSpec`), in the registry's order;
#: the tables below are derived from their ``extension`` parameters.
EFFECTS = tuple(REGISTRY.values())
NAMES = tuple(REGISTRY)
PARAMS = tuple(p for e in EFFECTS for p in e.extension)
EXTRA_NAMES = tuple(p.name for p in PARAMS)
N_EXTRA = len(EXTRA_NAMES)
N_PARAMS = len(PARAM_NAMES) + N_EXTRA
NEUTRAL = np.array([p.neutral for p in PARAMS])
#: (N_PARAMS,) the entries that cross-validation folds keep at the full-data fit (``Param.fold_fixed``).
FOLD_FIXED = np.array([False] * len(PARAM_NAMES) + [p.fold_fixed for p in PARAMS])
#: (N_PARAMS,) the entries of an effect placed in time (one with a ``fold_fixed`` parameter): a fold
#: whose training samples all lie on one side of that time cannot size the effect either.
PLACED = np.array(
    [False] * len(PARAM_NAMES)
    + [any(q.fold_fixed for q in e.extension) for e in EFFECTS for _ in e.extension]
)
BOUNDS = (
    np.concatenate([POLACH_BOUNDS[0], np.array([p.lower for p in PARAMS])]),
    np.concatenate([POLACH_BOUNDS[1], np.array([p.upper for p in PARAMS])]),
)


def active_mask(names) -> jax.Array:
    """Boolean mask over the extra parameters switching on the effects in ``names``."""
    unknown = set(names) - set(NAMES)
    if unknown:
        raise ValueError(f"unknown effect(s) {sorted(unknown)}; expected some of {NAMES}")
    return jnp.array([e.name in names for e in EFFECTS for _ in e.params])


def unpack(params, active):
    """Split ``params`` (N_PARAMS,) into Polach ``theta`` (5,) and a dict of extras (inactive ones
    at their neutral value)."""
    extra = jnp.where(active, params[5:], NEUTRAL)
    return params[:5], dict(zip(EXTRA_NAMES, extra, strict=True))


#: Index of the rail change's time (a fraction of the duration) in the parameter vector.
U_CHANGE = len(PARAM_NAMES) + EXTRA_NAMES.index("u_change")


def change_time(u, sig: Signals):
    """The rail change's time [s] at ``u_change = u`` [-] of the recording's duration."""
    return sig.time[0] + u * sig.duration


@jax.jit
def predict(params, active, sig: Signals):
    """``(target, prediction)`` of the observed adhesion [-], each shape (n,) (module docstring);
    jitted (inside a fit it is inlined; called on its own it is one program, not op by op)."""
    theta, e = unpack(params, active)
    target = sig.adhesion + e["delay_s"] * sig.torque_rate
    gain_r = 1.0 + e["delta_r"]
    slip = sig.wheel_speed * gain_r - sig.speed
    step = jax.nn.sigmoid((sig.time - change_time(e["u_change"], sig)) / (STEP_WIDTH * sig.duration))
    scale = (
        (1.0 - e["drop"] * step)
        * (1.0 - e["slope"] * (sig.speed - sig.speed_ref) / sig.speed_ref)
        / jnp.maximum(1.0 + e["softening"] * sig.heat / POWER_REF, 0.05)
    )
    ones = jnp.ones_like(slip)
    thetas = jnp.stack(
        [theta[0] * ones, theta[1] * ones, theta[2] * scale, theta[3] * ones, theta[4] * ones], axis=-1
    )
    # errors in variables: the curve at the mean of the slip's sign-truncated law (.slip_law)
    slip = truncated_mean(slip, sig.slip_sd, sig.adhesion)
    creep = creepage(slip, sig.speed)
    traction = polach_adhesion(thetas, creep, slip, sig.k_eps)  # F_t/(M g), all axles at static load
    load = jnp.maximum(1.0 - e["load_m"] * traction - e["load_accel"] * sig.accel / GRAVITY, 0.1)
    mu = polach_adhesion(thetas, creep, slip, sig.k_eps * load ** (-1.0 / 3.0))
    return target, gain_r * load * mu + e["offset"]


def residual(params, args):
    """Weighted residual ``w·(target − pred)`` for LM; ``args = (active, weights, sig)``."""
    active, weights, sig = args
    target, pred = predict(params, active, sig)
    return weights * (target - pred)
