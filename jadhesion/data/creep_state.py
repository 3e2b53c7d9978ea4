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
``q_v`` at that ``q_w``), each grid in one vmapped scan (2 × 13 filter passes: most of the
smoother's cost). Noise correlated over longer than a few samples (coloured sensor noise) is not
separable from motion in one recording; it is partly tracked as signal, and the reported standard
deviations then understate the error (by 10–30 % at the simulator's realistic sensors, 1.4–4.4× under
the independent generator's). Where the recording coasts, :func:`coasting_sd_scale` measures that
understatement — while coasting the true slip is a small fraction of the sensors' noise, so the
smoothed slip there *is* its error — and :func:`jadhesion.data.dataset.to_dataset` scales the
standard deviations by it.

**Outputs** (:class:`CreepEstimate`): smoothed ``v``, ``w``, ``s = w / max(|v|, floor)``
(:data:`jadhesion.models.kinematics.SPEED_FLOOR`, never NaN at standstill), their standard
deviations from the smoother's covariance (``Var s = (Var w − 2 s Cov(w, v) + s² Var v) /
max(|v|, floor)²``), and the observer's adhesion from the smoothed wheel acceleration without
filter lag: ``μ̂ = (T − J (a + ẇ)/r) / (m g r)``. Everything is ``lax.scan``: linear in length.

**Cost.** A step is a few fused elementwise kernels, not a chain of small matrix products: the two
sensors' noises are independent, so the 2-vector update is two scalar updates (no inverse, no
determinant); ``F = I + Δt N`` is applied by moving rows of ``P``; the backward pass is the
modified Bryson–Frazier form of the RTS smoother (adjoints ``λ``, ``Λ``; no inverse of the
predicted covariance). Same likelihoods, means and covariances as the dense filter and RTS smoother
to rounding (``tests/test_creep_state.py``), in about a quarter of the CPU time
(``benchmarks/bench_smoother.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..models.kinematics import SPEED_FLOOR
from .segments import MIN_SPEED
from .vehicle import GRAVITY

#: log10 of the candidate process-noise densities q [m²/s⁵].
Q_GRID = np.arange(-8.0, 4.01, 1.0)
#: Smallest measurement sd [m/s] (a noise-free or coarsely quantised channel).
MIN_MEASUREMENT_SD = 1e-6
#: The sensors as the states they sum (rows of ``H``), in the order they are applied: vehicle speed
#: ``v``, wheel speed ``v + w`` (independent noises: one 2-vector update is these two scalar ones).
_SENSORS = ((0,), (0, 2))


#: Coasting for :func:`coasting_sd_scale`: ``|mu_hat|`` below this [-] while moving (half the
#: selection's coasting limit :data:`.segments.MIN_DRIVE_MU`: the true slip there, ``≈ mu_hat |v| /``
#: the curve's initial slope, is a fraction of a speed sensor's noise).
COAST_ADHESION = 0.01
#: Fewest coasting samples that calibrate the slip's sd (fewer: the smoother's sd as it is).
COAST_MIN_SAMPLES = 50
#: Median of the χ² law with one degree of freedom: ``median(z²) / 0.4549`` estimates ``E z²``.
_CHI2_1_MEDIAN = 0.45493642311957283


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


def difference_sd(y, valid=None):
    """White-noise sd of a smooth signal plus noise: ``1.4826 MAD(Δ³y) / √20``. ``valid``: (n,)
    mask of the real samples, padding only at the end (:func:`smooth_creep`); third differences
    that reach into the padding are left out of both medians (the same values as without it)."""
    d3 = jnp.diff(y, n=3)
    if valid is not None:
        d3 = jnp.where(valid[3:] > 0, d3, jnp.nan)  # nanmedian: jnp.median's arithmetic on the rest
    return 1.4826 * jnp.nanmedian(jnp.abs(d3 - jnp.nanmedian(d3))) / jnp.sqrt(20.0)


def _predict(x, p, dt, q):
    """``(F x, F P Fᵀ + Q)`` over a step ``dt`` [s], ``q = (q_v, q_w)``; ``F = I + dt N`` with
    ``N x = (a, 0, ẇ, 0)`` applied by moving rows (no gathers, no dots), exactly symmetric."""
    z = jnp.zeros_like(p[0])
    n_p = jnp.stack([p[1], z, p[3], z])  # N P
    p = p + dt * (n_p + n_p.T) + dt**2 * jnp.stack([n_p[:, 1], z, n_p[:, 3], z], axis=1)
    base = jnp.stack([jnp.stack([dt**3 / 3, dt**2 / 2]), jnp.stack([dt**2 / 2, dt])])
    zb = jnp.zeros_like(base)
    p = p + jnp.block([[q[0] * base, zb], [zb, q[1] * base]])
    return x + dt * jnp.stack([x[1], z[0], x[3], z[0]]), p


def _mv(a, b):
    """``a @ b`` for a (4, 4) and a (4,) written as a sum of columns (fuses into the step)."""
    return sum(a[:, j] * b[j] for j in range(4))


def _update(x, p, idx, obs, r, real):
    """One scalar measurement ``obs = Σ_{i ∈ idx} x_i + e``, ``Var e = r``: updated mean and
    covariance, the log-likelihood of ``obs`` and what the backward pass needs (gain ``k``, ``ν/s``,
    ``1/s``). Sums over the sensor's states instead of products with ``h``: no reductions. ``real``
    (1 or 0) scales the update: 0 on a padded sample (no update, no likelihood, zero gain)."""
    ph = sum(p[:, i] for i in idx)
    s = sum(ph[i] for i in idx) + r
    nu = obs - sum(x[i] for i in idx)
    ll = -0.5 * (jnp.log(2.0 * jnp.pi * s) + nu * nu / s)
    k, nu_s, inv_s = real * (ph / s), real * (nu / s), real / s
    return x + ph * nu_s, p - real * (ph[:, None] * ph[None, :] / s), real * ll, (k, nu_s, inv_s)


def _initial(y, r):
    x0 = jnp.array([y[0, 1], 0.0, y[0, 0] - y[0, 1], 0.0])
    p0 = jnp.diag(jnp.array([r[1], 1.0, r[0] + r[1], 1.0]))
    return x0, p0


def _filter(y, dts, r, q, valid, keep=True):
    """Kalman filter over ``y`` (n, 2) = (wheel speed, vehicle speed) with steps ``dts`` (n − 1,):
    its exact log-likelihood (prediction-error decomposition) and, with ``keep``, per sample the
    predicted mean (n, 4) and covariance (n, 4, 4) and each update's ``(k, ν/s, 1/s)`` (stacked
    vehicle, wheel) for :func:`_smooth`. Sample 0 is a zero step from the prior :func:`_initial`.
    ``valid`` (n,): 1 for a sample, 0 for end padding (no update there)."""
    obs_r = (r[1], r[0])

    def step(carry, inputs):
        x, p, ll = carry
        obs, dt, real = inputs
        x, p = _predict(x, p, dt, q)
        xp, pp, parts = x, p, []
        for idx, o, rr in zip(_SENSORS, (obs[1], obs[0]), obs_r, strict=True):
            x, p, l1, part = _update(x, p, idx, o, rr, real)
            ll, parts = ll + l1, parts + [part]
        stored = (xp, pp, *(jnp.stack(a) for a in zip(*parts, strict=True))) if keep else None
        return (x, p, ll), stored

    x0, p0 = _initial(y, r)
    dts = jnp.concatenate([jnp.zeros(1, dts.dtype), dts])
    (_, _, ll), stored = jax.lax.scan(step, (x0, p0, jnp.zeros((), y.dtype)), (y, dts, valid))
    return (stored, ll) if keep else ll


def _smooth(stored, dts):
    """Backward pass (modified Bryson–Frazier: no matrix inverse): from the adjoint ``λ``, ``Λ`` of
    the predicted state, ``x̂ = x⁻ − P⁻ λ`` and ``P̂ = P⁻ − P⁻ Λ P⁻``. Returns the smoothed means
    (n, 4) and ``(Var v, Var w, Cov(v, w))`` (n,) each."""

    def step(carry, inputs):
        lam, big = carry
        (xp, pp, k, nu_s, inv_s), dt = inputs
        for j in (1, 0):  # the updates in reverse; Λ ← h hᵀ/s + Cᵀ Λ C, λ ← −h ν/s + Cᵀ λ, C = I − k hᵀ
            h = jnp.asarray(np.isin(np.arange(4), _SENSORS[j]), big.dtype)
            m = _mv(big, k[j])
            hm = h[:, None] * m[None, :]
            big = (
                big
                - (hm + hm.T)
                + (sum(k[j, i] * m[i] for i in range(4)) + inv_s[j]) * (h[:, None] * h[None, :])
            )
            lam = lam - h * (sum(k[j, i] * lam[i] for i in range(4)) + nu_s[j])
        x = xp - _mv(pp, lam)
        m0, m2 = _mv(big, pp[:, 0]), _mv(big, pp[:, 2])
        var = (
            pp[0, 0] - sum(pp[i, 0] * m0[i] for i in range(4)),
            pp[2, 2] - sum(pp[i, 2] * m2[i] for i in range(4)),
            pp[0, 2] - sum(pp[i, 0] * m2[i] for i in range(4)),
        )
        # to the step before: λ ← Fᵀ λ, Λ ← Fᵀ Λ F over dt (Nᵀ moves rows down)
        z = jnp.zeros_like(big[0])
        n_big = jnp.stack([z, big[0], z, big[2]])
        big = big + dt * (n_big + n_big.T) + dt**2 * jnp.stack([z, n_big[:, 0], z, n_big[:, 2]], axis=1)
        lam = lam + dt * jnp.stack([z[0], lam[0], z[0], lam[2]])
        return (lam, big), (x, jnp.stack(var))

    xp = stored[0]
    zero = (jnp.zeros_like(xp[0]), jnp.zeros_like(stored[1][0]))
    dts = jnp.concatenate([jnp.zeros(1, dts.dtype), dts])
    _, (xs, var) = jax.lax.scan(step, zero, (stored, dts), reverse=True)
    return xs, var.T


def _log_likelihood(y, dts, r, q, valid):
    return _filter(y, dts, r, q, valid, keep=False)


def estimate_noise(time, wheel_speed, vehicle_speed, valid=None):
    """``(measurement variances (R_w, R_v) [m²/s²], process densities (q_v, q_w) [m²/s⁵])`` of a
    recording (module docstring: differencing for R, grid maximum likelihood for q); ``valid`` as
    in :func:`smooth_creep`."""
    y = jnp.stack([wheel_speed, vehicle_speed], axis=1)
    dts = jnp.diff(time)
    sds = jnp.stack([difference_sd(wheel_speed, valid), difference_sd(vehicle_speed, valid)])
    r = jnp.maximum(sds, MIN_MEASUREMENT_SD) ** 2
    grid = jnp.asarray(10.0**Q_GRID, y.dtype)
    ll_many = jax.vmap(_log_likelihood, in_axes=(None, None, None, 0, None))
    real = jnp.ones(y.shape[0], y.dtype) if valid is None else jnp.asarray(valid, y.dtype)

    def best(qs):
        ll = ll_many(y, dts, r, qs, real)
        return qs[jnp.argmax(jnp.where(jnp.isfinite(ll), ll, -jnp.inf))]

    q_w = best(jnp.stack([jnp.full_like(grid, grid[0]), grid], axis=1))[1]
    q_v = best(jnp.stack([grid, jnp.full_like(grid, q_w)], axis=1))[0]
    return r, jnp.stack([q_v, q_w])


@jax.jit
def smooth_creep(time, wheel_speed, vehicle_speed, torque, inertia, wheel_radius, axle_load, valid=None):
    """:class:`CreepEstimate` of a recording from its four raw signals (each (n,), SI units; the
    vehicle's ``J`` [kg·m²], nominal ``r`` [m] and axle load [kg] for ``μ̂``). Pure and jitted;
    vmap over recordings of one length.

    ``valid`` (n,), optional: 1 for a recorded sample, 0 for padding after the last one (time
    repeated: zero steps), so that recordings of different lengths share one compiled program.
    Padding takes no part in the noise levels, the likelihood or the updates, so the estimate of
    the recorded samples is the unpadded one (to rounding); the padded rows repeat the last state.
    """
    time, wheel_speed, vehicle_speed, torque = (
        jnp.asarray(a, jnp.result_type(float)) for a in (time, wheel_speed, vehicle_speed, torque)
    )
    r, q = estimate_noise(time, wheel_speed, vehicle_speed, valid)
    dts = jnp.diff(time)
    y = jnp.stack([wheel_speed, vehicle_speed], axis=1)
    real = jnp.ones(y.shape[0], y.dtype) if valid is None else jnp.asarray(valid, y.dtype)
    stored, _ = _filter(y, dts, r, q, real)
    xm, (var_v, var_w, cov) = _smooth(stored, dts)
    v, a, w, wd = xm.T
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


@jax.jit
def coasting_sd_scale(slip, slip_sd, adhesion, vehicle_speed, valid=None):
    """``(scale, samples)``: the factor [-] by which the smoother's ``slip_sd`` understates the
    smoothed slip's error, measured on the recording's coasting samples (``|adhesion| <``
    :data:`COAST_ADHESION`, ``|v| ≥`` :data:`.segments.MIN_SPEED`, ``slip_sd > 0``; ``valid`` as
    in :func:`smooth_creep`), and their count. The small true slip of coasting, ``w ≈ c · mu_hat
    |v|`` with ``c`` the inverse initial slope, is fitted (least squares) and removed; the scale
    is the robust RMS ``√(median(z²) / 0.4549)`` of ``z = (ŵ − c mu_hat |v|) / slip_sd``, floored at
    1 (the smoother leaves out coloured noise; it adds none), and 1 with fewer than
    :data:`COAST_MIN_SAMPLES` such samples. Inputs (n,) [m/s, -]; traceable.

    On the independent generator's recordings with coasting (16 of 20 clean, mild and realistic
    sensors, 20–200 Hz) the true understatement was 1.35–4.4× and this scale 1.17–5.4×: true over
    estimated 0.80–1.49, median 0.97."""
    return coasting_scale(*coasting_residual(slip, slip_sd, adhesion, vehicle_speed, valid))


def coasting_scale(coast, z):
    """``(scale, samples)`` of :func:`coasting_sd_scale` from :func:`coasting_residual`'s coasting
    samples and standardised errors (for a caller that needs both). Traceable."""
    count = jnp.sum(coast)
    scale = jnp.sqrt(jnp.nanmedian(jnp.where(coast, z * z, jnp.nan)) / _CHI2_1_MEDIAN)
    return jnp.where(count >= COAST_MIN_SAMPLES, jnp.maximum(scale, 1.0), 1.0), count


def coasting_residual(slip, slip_sd, adhesion, vehicle_speed, valid=None):
    """``(coast, z)``: the coasting samples (n,) bool of :func:`coasting_sd_scale` and the smoothed
    slip's standardised error there, ``z = (ŵ − c mu_hat |v|) / slip_sd`` (0 elsewhere), the
    small true coasting slip ``c mu_hat |v|`` fitted by least squares and removed. Traceable."""
    real = jnp.ones(slip.shape, bool) if valid is None else jnp.asarray(valid) > 0
    moving = jnp.abs(vehicle_speed) >= MIN_SPEED
    coast = real & moving & (jnp.abs(adhesion) < COAST_ADHESION) & (slip_sd > 0)
    x = jnp.where(coast, adhesion * jnp.abs(vehicle_speed), 0.0)
    y = jnp.where(coast, slip, 0.0)
    xx = jnp.sum(x * x)
    c = jnp.where(xx > 0, jnp.sum(x * y) / jnp.where(xx > 0, xx, 1.0), 0.0)
    return coast, jnp.where(coast, (y - c * x) / jnp.where(coast, slip_sd, 1.0), 0.0)


def smooth_recording(recording, valid=None) -> CreepEstimate:
    """:func:`smooth_creep` of a recording (anything with ``columns`` holding the four raw signals
    and a ``vehicle``); ``valid`` as there."""
    c, veh = recording.columns, recording.vehicle
    return smooth_creep(
        c["time"],
        c["wheel_speed"],
        c["vehicle_speed"],
        c["traction_torque"],
        veh.wheelset_inertia_kgm2,
        veh.wheel_radius_m,
        veh.axle_load_kg,
        valid,
    )
