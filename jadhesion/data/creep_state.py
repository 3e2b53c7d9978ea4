"""Creep as an estimated state: a Kalman filter + RTS smoother on the recorded speeds.

Differencing two noisy speeds into slip ``w = v_w − v`` puts the sum of both sensors' noise into the
creep, which through Polach's steep initial slope attenuates the identified slope (errors in
variables). Here slip and vehicle speed are *states* of a linear Gauss–Markov model of the vehicle
and wheelset motion, estimated from the whole recording by a fixed-interval (RTS) smoother.

**Model** (state ``x = [v, a, w, ẇ]``: vehicle speed [m/s] and acceleration [m/s²], slip velocity
[m/s] and its rate [m/s²]). The heavy vehicle's acceleration and the slip rate are integrated random
walks (their derivatives white with spectral densities ``q_v`` [m²/s⁵], ``q_w`` [m²/s⁵]) — the
dynamics ``M v̇ = ΣF`` and ``J ω̇ = T − μ N r`` with forces that vary smoothly. Over a step ``Δt``
(any spacing, from the recording's ``time``) each block has

    F = [[1, Δt], [0, 1]],     Q = q [[Δt³/3, Δt²/2], [Δt²/2, Δt]],

and the sensors see ``y_w = v + w + e_w`` (wheel speed), ``y_v = v + e_v`` (vehicle speed), with
white noise of variances ``R_w``, ``R_v``.

**Noise levels from the recording itself.** ``R`` of each channel: the third difference of a
smooth signal is nearly zero while white noise gives ``Var(Δ³e) = 20 σ²``, so
``σ = 1.4826 · MAD(Δ³y) / √20`` (robust to slip excursions). ``q_v``, ``q_w``: maximum of the
Kalman filter's exact Gaussian log-likelihood (prediction-error decomposition) over a log grid
(:data:`Q_GRID`, decade steps; first ``q_w`` at the smallest ``q_v`` — a heavy vehicle — then
``q_v`` at that ``q_w``), each grid in one vmapped scan (2 × 13 filter passes: the cost of the
smoother). Noise correlated over longer than a few samples (coloured sensor noise) is not
separable from motion in one recording; it is partly tracked as signal, and the reported standard
deviations then understate the error (by 10–30 % at the simulator's realistic sensors).

**Outputs** (:class:`CreepEstimate`): smoothed ``v``, ``w``, ``s = w / max(|v|, floor)``
(:data:`jadhesion.models.kinematics.SPEED_FLOOR`, never NaN at standstill), their standard
deviations from the smoother's covariance (``Var s = (Var w − 2 s Cov(w, v) + s² Var v) /
max(|v|, floor)²``), and the observer's adhesion from the smoothed wheel acceleration without
filter lag: ``μ̂ = (T − J (a + ẇ)/r) / (m g r)``. Everything is ``lax.scan``: linear in length.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..models.kinematics import SPEED_FLOOR
from .vehicle import GRAVITY

#: log10 of the candidate process-noise densities q [m²/s⁵].
Q_GRID = np.arange(-8.0, 4.01, 1.0)
#: Smallest measurement sd [m/s] (a noise-free or coarsely quantised channel).
MIN_MEASUREMENT_SD = 1e-6
_H = np.array([[1.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0]])


class CreepEstimate(NamedTuple):
    """Smoothed states (each (n,)) and the noise levels they were estimated with."""

    vehicle_speed: jax.Array  # v [m/s]
    slip: jax.Array  # w [m/s]
    creep: jax.Array  # s [-]
    vehicle_speed_sd: jax.Array
    slip_sd: jax.Array
    creep_sd: jax.Array
    acceleration: jax.Array  # a [m/s²]
    slip_rate: jax.Array  # ẇ [m/s²]
    adhesion: jax.Array  # μ̂ from the smoothed wheel acceleration [-]
    measurement_sd: jax.Array  # (wheel, vehicle) [m/s]
    process_q: jax.Array  # (q_v, q_w) [m²/s⁵]


def difference_sd(y):
    """White-noise sd of a smooth signal plus noise: ``1.4826 MAD(Δ³y) / √20``."""
    d3 = jnp.diff(y, n=3)
    return 1.4826 * jnp.median(jnp.abs(d3 - jnp.median(d3))) / jnp.sqrt(20.0)


def _transition(dt, q_v, q_w):
    z = jnp.zeros((2, 2), dt.dtype)
    f = jnp.array([[1.0, 0.0], [0.0, 1.0]], dt.dtype) + jnp.array([[0.0, 1.0], [0.0, 0.0]]) * dt
    base = jnp.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    F = jnp.block([[f, z], [z, f]])
    Q = jnp.block([[q_v * base, z], [z, q_w * base]])
    return F, Q


def _initial(y, r):
    x0 = jnp.array([y[0, 1], 0.0, y[0, 0] - y[0, 1], 0.0])
    p0 = jnp.diag(jnp.array([r[1], 1.0, r[0] + r[1], 1.0]))
    return x0, p0


def _filter(y, dts, r, q, keep=True):
    """Kalman filter: filtered means/covariances (n, 4)/(n, 4, 4), predicted ones for steps 1..n−1,
    and the log-likelihood of ``y`` (n, 2) = (wheel speed, vehicle speed); with ``keep=False`` the
    log-likelihood only (nothing stored per step: the noise grid's passes)."""
    H = jnp.asarray(_H, y.dtype)
    R = jnp.diag(r)

    def update(x, p, obs):
        s = H @ p @ H.T + R
        innov = obs - H @ x
        # 2 × 2 innovation covariance inverted in closed form (the same numbers to rounding as a
        # LAPACK solve and slogdet, at half the cost of a filter step)
        det = s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]
        s_inv = jnp.stack([jnp.stack([s[1, 1], -s[0, 1]]), jnp.stack([-s[1, 0], s[0, 0]])]) / det
        k = (s_inv @ (H @ p)).T
        ll = -0.5 * (jnp.log(det) + innov @ s_inv @ innov + 2.0 * jnp.log(2.0 * jnp.pi))
        p = p - k @ H @ p
        return x + k @ innov, 0.5 * (p + p.T), ll

    x0, p0 = _initial(y, r)
    x0, p0, ll0 = update(x0, p0, y[0])

    def step(carry, inputs):
        x, p, ll = carry
        obs, dt = inputs
        F, Q = _transition(dt, q[0], q[1])
        xp, pp = F @ x, F @ p @ F.T + Q
        x, p, l1 = update(xp, pp, obs)
        return (x, p, ll + l1), ((x, p, xp, pp) if keep else None)

    (_, _, ll), stored = jax.lax.scan(step, (x0, p0, ll0), (y[1:], dts))
    if not keep:
        return ll
    xs, ps, xps, pps = stored
    return (jnp.concatenate([x0[None], xs]), jnp.concatenate([p0[None], ps]), xps, pps, ll)


def _smooth(xs, ps, xps, pps, dts, q):
    """Rauch–Tung–Striebel backward pass: smoothed means (n, 4) and covariances (n, 4, 4)."""

    def step(carry, inputs):
        xs_next, ps_next = carry
        x, p, xp, pp, dt = inputs
        F, _ = _transition(dt, q[0], q[1])
        g = jnp.linalg.solve(pp, F @ p).T
        x_s = x + g @ (xs_next - xp)
        p_s = p + g @ (ps_next - pp) @ g.T
        p_s = 0.5 * (p_s + p_s.T)
        return (x_s, p_s), (x_s, p_s)

    _, (xb, pb) = jax.lax.scan(step, (xs[-1], ps[-1]), (xs[:-1], ps[:-1], xps, pps, dts), reverse=True)
    return jnp.concatenate([xb, xs[-1:]]), jnp.concatenate([pb, ps[-1:]])


def _log_likelihood(y, dts, r, q):
    return _filter(y, dts, r, q, keep=False)


def estimate_noise(time, wheel_speed, vehicle_speed):
    """``(measurement variances (R_w, R_v) [m²/s²], process densities (q_v, q_w) [m²/s⁵])`` of a
    recording (module docstring: differencing for R, grid maximum likelihood for q)."""
    y = jnp.stack([wheel_speed, vehicle_speed], axis=1)
    dts = jnp.diff(time)
    r = (
        jnp.maximum(jnp.stack([difference_sd(wheel_speed), difference_sd(vehicle_speed)]), MIN_MEASUREMENT_SD)
        ** 2
    )
    grid = jnp.asarray(10.0**Q_GRID, y.dtype)
    ll_many = jax.vmap(_log_likelihood, in_axes=(None, None, None, 0))

    def best(qs):
        ll = ll_many(y, dts, r, qs)
        return qs[jnp.argmax(jnp.where(jnp.isfinite(ll), ll, -jnp.inf))]

    q_w = best(jnp.stack([jnp.full_like(grid, grid[0]), grid], axis=1))[1]
    q_v = best(jnp.stack([grid, jnp.full_like(grid, q_w)], axis=1))[0]
    return r, jnp.stack([q_v, q_w])


@jax.jit
def smooth_creep(time, wheel_speed, vehicle_speed, torque, inertia, wheel_radius, axle_load):
    """:class:`CreepEstimate` of a recording from its four raw signals (each (n,), SI units; the
    vehicle's ``J`` [kg·m²], nominal ``r`` [m] and axle load [kg] for ``μ̂``). Pure and jitted;
    vmap over recordings of one length."""
    time, wheel_speed, vehicle_speed, torque = (
        jnp.asarray(a, jnp.result_type(float)) for a in (time, wheel_speed, vehicle_speed, torque)
    )
    r, q = estimate_noise(time, wheel_speed, vehicle_speed)
    dts = jnp.diff(time)
    y = jnp.stack([wheel_speed, vehicle_speed], axis=1)
    xs, ps, xps, pps, _ = _filter(y, dts, r, q)
    xm, pm = _smooth(xs, ps, xps, pps, dts, q)
    v, a, w, wd = xm.T
    var_v, var_w, cov = pm[:, 0, 0], pm[:, 2, 2], pm[:, 0, 2]
    speed = jnp.maximum(jnp.abs(v), SPEED_FLOOR)
    s = w / speed
    var_s = jnp.maximum(var_w - 2.0 * s * cov + s * s * var_v, 0.0) / speed**2
    mu = (torque - inertia * (a + wd) / wheel_radius) / (axle_load * GRAVITY * wheel_radius)
    return CreepEstimate(
        v,
        w,
        s,
        jnp.sqrt(jnp.maximum(var_v, 0.0)),
        jnp.sqrt(jnp.maximum(var_w, 0.0)),
        jnp.sqrt(var_s),
        a,
        wd,
        mu,
        jnp.sqrt(r),
        q,
    )


def smooth_recording(recording) -> CreepEstimate:
    """:func:`smooth_creep` of a recording (anything with ``columns`` holding the four raw signals
    and a ``vehicle``)."""
    c, veh = recording.columns, recording.vehicle
    return smooth_creep(
        c["time"],
        c["wheel_speed"],
        c["vehicle_speed"],
        c["traction_torque"],
        veh.wheelset_inertia_kgm2,
        veh.wheel_radius_m,
        veh.axle_load_kg,
    )
