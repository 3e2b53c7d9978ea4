"""The law of the true slip given the smoothed one: normal about it (the default) or under the
recording's own slips as the prior (opt-in), truncated to the sign of the force either way.

The creep smoother (:mod:`jadhesion.data.creep_state`) gives each sample a slip ``ŵ`` [m/s] and a
standard deviation ``sd`` [m/s]. Polach's law is odd in the slip, so a wheel that pulls
(``mu_hat > 0``) slips forward, and the sign of ``mu_hat`` is known far better than the slip's at
walking pace: a torque sensor resolves ~0.001 of the axle's weight, a speed sensor 1–10 mm/s, the
width of the whole micro-slip region. The true slip of a sample with ``|mu_hat| ≥``
:data:`SLIP_SIGN_MIN` is therefore taken as ``N(ŵ, sd²)`` truncated to ``sign(mu_hat)·w ≥ 0``
(below it, untruncated).

Why it matters: without the truncation a smoothed slip near 0 reads as "half the time backwards";
the expected curve then passes through 0 there while the data stay at the adhesion of a small
forward slip, and the misfit looks like a torque offset or a radius error. On the independent
generator's clean 25 Hz starts (``validation/foreign_generator.py``, seed 11058, speed sensors
1.4–2.7 mm/s white + AR): the untruncated base fit had kA 0.14 against a true 1.0 and an offset took
78 % of its sum of squares; truncated, the base sum of squares fell 3.6× and the offset took 30 %.

**The slips' population as the prior** (:func:`population_law`, :func:`posterior_nodes`; the
``"population"`` law of :func:`.likelihood.with_node_slips`, opt-in). A normal law about ``ŵ`` is
right when the smoother's error is *Berkson* (uncorrelated with ``ŵ``), as measured on the
independent generator. On our simulator's steady starts it is mostly *classical* (uncorrelated
with the true slip: the error's regression on ``ŵ`` 0.33–0.72 in the lower three quartiles of dry
and wet starts) and the slips crowd within 1–2 sds; the true slip given ``ŵ`` is then drawn toward
where the recording's slips lie, and the normal law biases the expected curve (LM with the *true*
adhesion as the target took kA to its bound and μ0 +0.027 on dry starts). The population law
``g`` is deconvolved from the recording by Richardson–Lucy (the EM of ``ŵ_i ~ Σ_k g_k N(s_k, sd_i²
+ h_k²)`` over an asinh grid ``s_k`` of spacing ``h_k``, sign-truncated like the rest) from a flat
start, stopped after :data:`PRIOR_ITERATIONS` (early stopping regularises: run on, the estimate
becomes a few spikes, and one fit in 12 of the independent generator went wrong with it). The
posterior of sample i, ``∝ g(s) N(ŵ_i; s, sd_i²)``, is evaluated on a local grid ``ŵ_i + sd_i t``
and its quantiles at ``Φ(z_j)`` are the nodes: where ``g`` is flat over ``±sd_i`` they are the
truncated normal's. Measured (README, "Which slip law"): on our dry starts μ0's 90 % interval held
the truth in 10 of 12 instead of 3; where the error is partly Berkson (sand) it shrinks too far
and the initial slope comes out low. Cost, compiled, once per fit: 25 ms on 2 000 rows, 89 ms on
36 000, 0.6 s on 360 000 (the normal law's nodes 0.4, 4.4 and 43 ms; a 2-core CPU under load),
linear beyond :data:`PRIOR_ROWS`.

Two forms of the sign-truncated normal:

* :func:`slip_nodes` — Gauss–Hermite nodes mapped onto the truncated normal, for expectations of the
  curve (LM's residual, the posterior): ``e_j = σ u_j``, ``u_j = −Φ⁻¹(Φ(−a) Φ(−z_j))`` ≥
  ``a = −σ ŵ/sd`` (``σ = sign(mu_hat)``; ``u_j = z_j`` far from the bound).
* :func:`truncated_mean` — the law's mean ``ŵ + σ sd φ(a)/Φ(−a)``, one evaluation of the curve
  instead of :data:`GH_NODES` (the diagnosis's many fits; the offset's SSE share on seeds 11058
  and 11061 was 0.32 and 0.28 with it, 0.30 and 0.34 with the 7-node expectation).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import log_ndtr, ndtr, ndtri

#: Smallest |mu_hat| [-] whose sign truncates the slip's law (the force direction is known).
SLIP_SIGN_MIN = 0.01
#: Standardised bound beyond which the tail's limit law replaces the exact inverse (Φ(−a) ~ 1e-198).
TAIL = 30.0
#: Gauss–Hermite nodes of the errors-in-variables expectation over the slip.
GH_NODES = 7
_GH_Z, _GH_W = np.polynomial.hermite_e.hermegauss(GH_NODES)
#: The quadrature weights (GH_NODES,), summing to 1.
GH_WEIGHTS = _GH_W / _GH_W.sum()
#: The population law's grid: points, ``c sinh(u)`` with ``u`` uniform and ``c`` this many median
#: sds (fine where the slips crowd near 0, logarithmic to the macro-slip tail).
PRIOR_POINTS, PRIOR_SCALE = 256, 4.0
#: Rows (evenly strided) and Richardson–Lucy iterations of the population law's estimate.
PRIOR_ROWS, PRIOR_ITERATIONS = 4096, 30
#: Local grid of each sample's posterior: ``t`` from −LOCAL_WIDTH to LOCAL_WIDTH sds, LOCAL_POINTS
#: points; rows per block of that computation (memory: a block's (rows, points) arrays).
LOCAL_WIDTH, LOCAL_POINTS, LOCAL_BLOCK = 6.0, 49, 8192


def _sign(adhesion):
    """The force's sign (n,): ``sign(mu_hat)`` where ``|mu_hat| ≥`` :data:`SLIP_SIGN_MIN`, else 0."""
    return jnp.where(jnp.abs(adhesion) >= SLIP_SIGN_MIN, jnp.sign(adhesion), 0.0)


def _bound(slip, slip_sd, adhesion):
    """``(σ, a)``: the sign of the force (0: untruncated) and the standardised bound ``−σ ŵ/sd``
    (finite: ``sd`` floored at the dtype's smallest normal)."""
    sign = _sign(adhesion)
    tiny = jnp.finfo(slip.dtype).tiny
    a = jnp.clip(-sign * slip / jnp.maximum(slip_sd, tiny), -1.0 / tiny, 1.0 / tiny)
    return sign, a


def slip_nodes(slip, slip_sd, adhesion):
    """Standardised nodes ``e`` (GH_NODES, n): the true slip at node j is ``slip + slip_sd · e_j``,
    each with weight :data:`GH_WEIGHTS` ``[j]`` (module docstring). Inputs (n,): slip, slip_sd
    [m/s], adhesion ``mu_hat`` [-]. Beyond ``a`` = :data:`TAIL` (the smoothed slip far on the wrong
    side, where ``Φ(−a)`` underflows) the tail's limit law ``u = a + Exp(1)/a`` is used."""
    z = jnp.asarray(_GH_Z, slip.dtype)[:, None]
    sign, a = _bound(slip, slip_sd, adhesion)
    near = jnp.minimum(a, TAIL)[None, :]
    far = jnp.maximum(a, TAIL)[None, :]
    u = jnp.where(a[None, :] <= TAIL, -ndtri(ndtr(-near) * ndtr(-z)), far - log_ndtr(-z) / far)
    return jnp.where(sign[None, :] == 0, z, sign[None, :] * u)


@jax.jit
def node_slips(slip, slip_sd, adhesion):
    """The true slips [m/s] (GH_NODES, n) at the sign-truncated normal's nodes,
    ``slip + slip_sd · e_j`` (:func:`slip_nodes`; inputs as there). Jitted: op by op (an eager
    caller's dataset) the inverse normal CDFs took ~0.6 s a call."""
    return slip[None, :] + slip_sd[None, :] * slip_nodes(slip, slip_sd, adhesion)


def node_moments(values):
    """Mean and variance (n,) of ``values`` (GH_NODES, n), a function at each node, under the
    quadrature weights :data:`GH_WEIGHTS` (the variance floored at 0 against rounding)."""
    weights = jnp.asarray(GH_WEIGHTS, values.dtype)[:, None]
    mean = jnp.sum(weights * values, axis=0)
    return mean, jnp.maximum(jnp.sum(weights * (values - mean[None, :]) ** 2, axis=0), 0.0)


def truncated_mean(slip, slip_sd, adhesion):
    """Mean [m/s] (n,) of the true slip's law: ``slip + σ slip_sd φ(a)/Φ(−a)`` (module docstring;
    ``slip`` where untruncated or ``slip_sd`` is 0; beyond ``a`` = :data:`TAIL` the Mills ratio's
    expansion ``φ(a)/Φ(−a) = a + 1/a − 2/a³ + …``, on the force's side for any input)."""
    sign, a = _bound(slip, slip_sd, adhesion)
    near = jnp.minimum(a, TAIL)
    far = jnp.maximum(a, TAIL)
    mills = jnp.exp(-0.5 * near * near - 0.5 * jnp.log(2.0 * jnp.pi) - log_ndtr(-near))
    beyond = sign * slip_sd * (1.0 / far - 2.0 / far**3 + 10.0 / far**5)  # = slip + σ sd mills
    mean = jnp.where(a <= TAIL, slip + sign * slip_sd * mills, beyond)
    return jnp.where((sign == 0) | (slip_sd <= 0), slip, mean)


def _allowed(sign, slip):
    """1 where a slip ``slip`` [m/s] lies on the force's side (or the sign is unknown), else 0."""
    return jnp.where((sign == 0) | (sign * slip >= 0), 1.0, 0.0)


def population_law(slip, slip_sd, adhesion, weight=None):
    """``(grid, log_density)`` (each (:data:`PRIOR_POINTS`,), [m/s], log [s/m]): the law of the
    recording's true slips, deconvolved from the smoothed ones (module docstring): a mixture of
    normals at the grid points, each as wide as the grid's local spacing ``h_k``, whose weights are
    Richardson–Lucy's (the EM of ``ŵ_i ~ Σ_k g_k N(s_k, sd_i² + h_k²)``); its log density at the
    grid points. Inputs (n,); ``weight`` (n,): 1 for a sample, 0 for padding (left out).
    Traceable."""
    real = jnp.ones_like(slip) if weight is None else jnp.asarray(weight, slip.dtype)
    if slip.shape[0] > PRIOR_ROWS:  # evenly strided over the samples (padding comes last)
        count = jnp.sum(real > 0)
        idx = jnp.round(jnp.arange(PRIOR_ROWS) * ((count - 1) / (PRIOR_ROWS - 1))).astype(jnp.int32)
        slip, slip_sd, adhesion, real = slip[idx], slip_sd[idx], adhesion[idx], real[idx]
    use = real > 0
    median_sd = jnp.nanmedian(jnp.where(use & (slip_sd > 0), slip_sd, jnp.nan))
    c = PRIOR_SCALE * jnp.where(median_sd > 0, median_sd, 1e-6)  # NaN (no sd > 0) compares False
    lo = jnp.min(jnp.where(use, slip - LOCAL_WIDTH * slip_sd, jnp.inf))
    hi = jnp.max(jnp.where(use, slip + LOCAL_WIDTH * slip_sd, -jnp.inf))
    grid = c * jnp.sinh(jnp.linspace(jnp.arcsinh(lo / c), jnp.arcsinh(hi / c), PRIOR_POINTS))
    h = jnp.gradient(grid)
    var = slip_sd[:, None] ** 2 + h[None, :] ** 2
    z2 = (slip[:, None] - grid[None, :]) ** 2 / var
    lik = jnp.exp(-0.5 * z2) / jnp.sqrt(var) * _allowed(_sign(adhesion)[:, None], grid[None, :])
    weights = jnp.where(use, 1.0, 0.0) / jnp.maximum(jnp.sum(use), 1)

    def em(_, g):
        m = lik * g[None, :]
        m = m / jnp.maximum(jnp.sum(m, axis=1, keepdims=True), jnp.finfo(m.dtype).tiny)
        return jnp.sum(weights[:, None] * m, axis=0)

    g = jax.lax.fori_loop(0, PRIOR_ITERATIONS, em, jnp.full(PRIOR_POINTS, 1.0 / PRIOR_POINTS, slip.dtype))
    bumps = jnp.exp(-0.5 * ((grid[:, None] - grid[None, :]) / h[None, :]) ** 2) / h[None, :]
    density = jnp.sum(bumps * g[None, :], axis=1) / jnp.sqrt(2.0 * jnp.pi)
    return grid, jnp.log(jnp.maximum(density, jnp.finfo(slip.dtype).tiny))


def posterior_nodes(slip, slip_sd, adhesion, weight=None):
    """Slips [m/s] (n, :data:`GH_NODES`) at the quantiles ``Φ(z_j)`` of each sample's posterior
    under :func:`population_law` (log density interpolated linearly between its grid points;
    module docstring), each with weight :data:`GH_WEIGHTS` ``[j]``; the sign-truncated normal's
    nodes where the local grid lies wholly on the wrong side of the force, ``slip`` where
    ``slip_sd`` is 0. Inputs (n,) as :func:`population_law`; traceable, memory in blocks of
    :data:`LOCAL_BLOCK` rows."""
    grid, log_density = population_law(slip, slip_sd, adhesion, weight)
    t = jnp.linspace(-LOCAL_WIDTH, LOCAL_WIDTH, LOCAL_POINTS, dtype=slip.dtype)
    p = jnp.asarray(ndtr(_GH_Z), slip.dtype)
    normal = node_slips(slip, slip_sd, adhesion).T

    def one(row):
        w, sd, mu, fallback = row
        sign, pts = _sign(mu), w + sd * t
        log_mass = -0.5 * t * t + jnp.interp(pts, grid, log_density)
        mass = jnp.exp(log_mass - jnp.max(log_mass)) * _allowed(sign, pts)
        total = jnp.sum(mass)
        cdf = (jnp.cumsum(mass) - 0.5 * mass) / jnp.where(total > 0, total, 1.0)
        nodes = jnp.interp(p, cdf, pts)
        # interpolating from the last point beyond w = 0 may step past it: back onto the force's side
        nodes = jnp.where(sign == 0, nodes, sign * jnp.maximum(sign * nodes, 0.0))
        return jnp.where(sd <= 0, w, jnp.where(total > 0, nodes, fallback))

    return jax.lax.map(one, (slip, slip_sd, adhesion, normal), batch_size=LOCAL_BLOCK)
