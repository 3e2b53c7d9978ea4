"""Online identification of the Kiencke model (paper 000, eqs 3–17).

Weighted least squares with a time-varying forgetting factor over the linear form
``Z = a_s λ − μ = Uᵀ x``, ``U = [λμ, λ²μ]``, ``x = [p1, p2]``:

    H(k) = η_k H(k−1) + w_k I(k),        I(k) = 2 U Uᵀ
    f(k) = η_k f(k−1) − w_k 2 Z U
    x(k) = argmin_x ½ xᵀH(k)x + f(k)ᵀx + ½ δ |x − x(k−1)|²  =  (H + δ1)⁻¹ (δ x(k−1) − f)

The ½ in front of ``xᵀHx`` (Matlab ``quadprog``'s convention) makes ``x`` the exact least-squares
solution of ``Σ(Z − Uᵀx)²`` given ``I = 2UUᵀ`` and ``f = −2ΣZU`` (without it the estimate would be
halved); ``δ`` is a Tikhonov pull towards the previous estimate that
keeps the solve finite while ``H`` is singular (first step, zero excitation) and vanishes at a fixed
point, so noise-free data are recovered exactly.

One step ``k`` does, in this order:

1. predict ``μ̂(k)`` with the previous estimate ``x(k−1)`` and form ``e = |μ̂(k) − μ(k)|``;
2. ``η_k = max(η_min, η_max − Kp e)`` (eq 9);
3. SNR test (eqs 10–17, only when enabled and ``k > 5``): ``X1 = {I(k), H(k−1), H(k−2)}``,
   ``X2 = {H(k−3), H(k−4), H(k−5)}``, element-wise means and population variances,
   ``S = (X̄1 − X̄2) / (S1 + S2)`` (``S = 0`` where ``S1 + S2 = 0``); when every element of ``S``
   lies in ``[a, b]`` (and ``e ≤ hold_error``: ``inf`` in the paper's algorithms),
   ``η_k = η_max``;
4. weight ``w_k = 1 − ω η_k / 2`` (``ω = 1``: the paper's ``(2 − η)/2``; ``ω = 0``: ``w = 1``);
5. update ``H, f`` and solve for ``x(k)``.

A sample flagged as not informative (``valid = False``: standstill, coasting, non-finite) is
skipped: the state is carried unchanged and the trace repeats the estimate with ``η = 1``.
:func:`final_status` grades a finished run (:class:`~jadhesion.status.Status`).

**Forgetting per second.** The paper's η is per sample, so the estimate's memory in seconds shrinks
with the logger's rate (on the independent generator's runs at 500 Hz Algorithm 2's tracked peak
was off by a median 14 %, 8 % at 50 Hz: ``benchmarks/online_rates.py``). A step of ``Δt`` may
instead forget ``η_k^(Δt/Δt_ref)``
(:func:`step_ratios`, ``Δt_ref`` = :data:`REFERENCE_STEP_S`, the 50 Hz at which the coefficients
were set): the same memory in seconds at any rate, the paper's at 50 Hz. η_k itself, the weight
``w_k`` and the SNR test stay per sample.

Every coefficient lives in :class:`OnlineParams` (arrays, so a sensitivity study vmaps over them).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from ..data.creep_state import difference_sd
from ..data.dataset import PolachDataset
from ..data.segments import gap_limit, longest_run
from ..models.effects import on_clock
from ..models.kiencke import DEFAULT_SLOPE, kiencke_adhesion, kiencke_regressors
from ..status import Status
from .batch_fit import pad_dataset
from .kiencke_fit import MIN_SAMPLES, fit_kiencke, informative
from .peak import extrapolation_warning
from .polach_fit import RECOMMENDED_SAMPLES


class OnlineParams(NamedTuple):
    """Coefficients of the online identifier (all array leaves; flags are 0.0/1.0).

    eta_min, eta_max: forgetting-factor limits [-]. kp: feedback gain on ``|μ̂ − μ|`` [-].
    weight_slope: ``ω`` in ``w = 1 − ω η/2``. snr: 1.0 enables the SNR (Granger) step.
    snr_lo, snr_hi: (2, 2) interval ``[a, b]`` of eq 17. a_s: Kiencke initial slope [-].
    delta: Tikhonov weight ``δ`` of the solve [same units as H]. x0: initial ``[p1, p2]``.
    hold_error: the SNR step holds ``η = η_max`` only while ``|μ̂ − μ|`` is at most this [-]
    (``inf``: always, the paper's).
    """

    eta_min: jax.Array
    eta_max: jax.Array
    kp: jax.Array
    weight_slope: jax.Array
    snr: jax.Array
    snr_lo: jax.Array
    snr_hi: jax.Array
    a_s: jax.Array
    delta: jax.Array
    x0: jax.Array
    hold_error: jax.Array


#: Feedback gain (not given by the paper): the knee of a sweep Kp ∈ {0.5 … 64} of Algorithm 1
#: without SNR on the default scenario (σ = 0.002, 200 seeds): p1 error 50 steps after the first rail
#: change 2.4 % at Kp = 4, 0.8 % at 8, 0.65 % at 16; steady RMS p2 error 0.78 %, 1.0 %, 1.3 %.
#: Noise-level errors (3σ = 0.006) then cost 0.05 of η; a rail change drives η to its floor.
DEFAULT_KP = 8.0
#: SNR interval of eq 17 (not given by the paper): element-wise 2.5–97.5 % quantiles of ``S`` on a
#: constant-rail, noise-only run of Algorithm 1 without the SNR step (``experiments.online.calibrate_snr``).
DEFAULT_SNR_LO = ((-6.8, -34.0), (-34.0, -160.0))
DEFAULT_SNR_HI = ((-0.8, 23.0), (23.0, 320.0))
#: Regularisation δ: far below the information of one sample, 2(λ²μ)² ≈ 2e-5 at λ = 0.1, μ = 0.35.
#: (Use float64: in float32 the 2×2 determinant of a near-singular H loses its sign to rounding.)
DEFAULT_DELTA = 1e-10
#: Initial estimate: neutral, none of the paper's rail sets.
DEFAULT_X0 = (100.0, 100.0)


def make_params(
    eta_min,
    eta_max,
    weight_slope,
    snr,
    *,
    kp=DEFAULT_KP,
    snr_lo=DEFAULT_SNR_LO,
    snr_hi=DEFAULT_SNR_HI,
    a_s=DEFAULT_SLOPE,
    delta=DEFAULT_DELTA,
    x0=DEFAULT_X0,
    hold_error=float("inf"),
) -> OnlineParams:
    """Build :class:`OnlineParams` with every leaf a float array (default float dtype)."""
    f = lambda v: jnp.asarray(v, dtype=float)  # noqa: E731
    return OnlineParams(
        *map(f, (eta_min, eta_max, kp, weight_slope, snr, snr_lo, snr_hi, a_s, delta, x0, hold_error))
    )


def algorithm1_params(**kw) -> OnlineParams:
    """Paper's Algorithm 1: ``η ∈ [0.251, 1]``, ``w = (2 − η)/2``, SNR step on (``kw`` overrides)."""
    return make_params(**{"eta_min": 0.251, "eta_max": 1.0, "weight_slope": 1.0, "snr": 1.0, **kw})


def algorithm2_params(**kw) -> OnlineParams:
    """Paper's Algorithm 2: ``η ∈ [0.971, 1]``, ``w = 1``, no SNR step (``kw`` overrides)."""
    return make_params(**{"eta_min": 0.971, "eta_max": 1.0, "weight_slope": 0.0, "snr": 0.0, **kw})


def rls_params(forgetting=0.98, **kw) -> OnlineParams:
    """Classic recursive least squares with constant forgetting (``Kp = 0``, ``w = 1``, no SNR)."""
    return make_params(
        **{"eta_min": forgetting, "eta_max": forgetting, "weight_slope": 0.0, "snr": 0.0, "kp": 0.0, **kw}
    )


def stack_params(params) -> OnlineParams:
    """Stack a sequence of :class:`OnlineParams` along a new leading axis (for ``vmap``)."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *params)


#: The sample step [s] at which the forgetting coefficients hold as they are (the paper's η limits
#: and :data:`DEFAULT_KP`, set on our simulator's 50 Hz): :func:`step_ratios`.
REFERENCE_STEP_S = 0.02
#: What the forgetting factor's memory is counted in: ``"seconds"`` (η^(Δt/Δt_ref) per step) or
#: ``"samples"`` (the paper's η per sample, whatever the rate).
FORGETTING = ("seconds", "samples")


def step_ratios(time) -> np.ndarray:
    """(n,) exponents ``Δt/``:data:`REFERENCE_STEP_S` of each sample's forgetting, ``Δt`` [s] the
    step from the previous row of ``time`` [s]; the first row and a step across a gap (longer than
    the selection's, :func:`jadhesion.data.segments.gap_limit`) take the median step,
    so the time a tracker holds across a gap, like the time of skipped samples, does not forget."""
    t = np.asarray(time, float)
    if t.size < 2:
        return np.ones_like(t)
    dt = np.diff(t)
    median = float(np.median(dt))
    dt = np.where(dt > gap_limit(dt), median, dt)
    return np.r_[median, dt] / REFERENCE_STEP_S


class OnlineState(NamedTuple):
    """H(k) (2, 2), f(k) (2,), x(k) (2,), history H(k−1..k−5) (5, 2, 2), steps done k."""

    h: jax.Array
    f: jax.Array
    x: jax.Array
    h_hist: jax.Array
    k: jax.Array


class OnlineInfo(NamedTuple):
    """Per-step trace: estimates, peak adhesion ``a_s/(p1 + 2√p2)``, optimum creep ``1/√p2``,
    the forgetting applied over the step (``η_k``, or ``η_k^(Δt/Δt_ref)`` per second), SNR matrix
    and hit flag."""

    p1: jax.Array
    p2: jax.Array
    mu_max: jax.Array
    creep_opt: jax.Array
    eta: jax.Array
    snr: jax.Array
    snr_hit: jax.Array


def init(params: OnlineParams) -> OnlineState:
    """Empty information (H = 0, f = 0) and the initial estimate ``x0``."""
    x0 = params.x0
    zero = jnp.zeros((2, 2), x0.dtype)
    return OnlineState(zero, jnp.zeros_like(x0), x0, jnp.zeros((5, 2, 2), x0.dtype), jnp.zeros((), jnp.int32))


def snr_matrix(info, h_hist):
    """Eqs 10–16: ``S = (X̄1 − X̄2)/(S1 + S2)`` element-wise; 0 where ``S1 + S2 = 0``."""
    x1 = jnp.stack([info, h_hist[0], h_hist[1]])
    x2 = h_hist[2:]
    m1, m2 = x1.mean(0, keepdims=True), x2.mean(0, keepdims=True)
    den = ((x1 - m1) ** 2).mean(0) + ((x2 - m2) ** 2).mean(0)
    safe = jnp.where(den > 0, den, 1.0)
    return jnp.where(den > 0, (m1 - m2)[0] / safe, 0.0)


def _solve_spd2(a, b):
    """``a⁻¹ b`` for a symmetric positive-definite 2×2 ``a`` by Cramer's rule (``det > 0``)."""
    det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    return jnp.stack([a[1, 1] * b[0] - a[0, 1] * b[1], a[0, 0] * b[1] - a[1, 0] * b[0]]) / det


def peak_adhesion(x, a_s):
    """``μ_m = a_s / (p1 + 2√max(p2, 0))`` (±inf, never NaN, for a non-positive denominator)."""
    return a_s / (x[..., 0] + 2.0 * jnp.sqrt(jnp.maximum(x[..., 1], 0.0)))


def optimum_creep(x):
    """``λ_m = 1/√p2`` [-]; ``+inf`` (no optimum, never NaN) where ``p2 ≤ 0``."""
    p2 = x[..., 1]
    return jnp.where(p2 > 0, 1.0 / jnp.sqrt(jnp.where(p2 > 0, p2, 1.0)), jnp.inf)


def step(params: OnlineParams, state: OnlineState, obs):
    """One identifier step on ``obs = (λ(k), μ(k))``, ``(λ(k), μ(k), valid(k))`` or
    ``(λ(k), μ(k), valid(k), ratio(k))`` (the forgetting's exponent, :func:`step_ratios`; 1: the
    paper's per-sample η); returns ``(state, info)`` (module docstring)."""
    lam, mu = obs[:2]
    valid = obs[2] if len(obs) > 2 else True
    ratio = obs[3] if len(obs) > 3 else 1.0
    lam = jnp.where(valid, lam, 0.0)
    mu = jnp.where(valid, mu, 0.0)
    z, u = kiencke_regressors(lam, mu, params.a_s)
    mu_hat = kiencke_adhesion(lam, state.x[0], state.x[1], params.a_s)
    eta = jnp.maximum(params.eta_min, params.eta_max - params.kp * jnp.abs(mu_hat - mu))
    info = 2.0 * jnp.outer(u, u)
    s = snr_matrix(info, state.h_hist)
    inside = jnp.all((s >= params.snr_lo) & (s <= params.snr_hi))
    hit = (params.snr > 0.5) & (state.k >= 5) & inside & (jnp.abs(mu_hat - mu) <= params.hold_error)
    eta = jnp.where(hit, params.eta_max, eta)
    w = 1.0 - params.weight_slope * eta / 2.0
    eta = eta**ratio
    h = eta * state.h + w * info
    f = eta * state.f - w * 2.0 * z * u
    x = _solve_spd2(h + params.delta * jnp.eye(2, dtype=h.dtype), params.delta * state.x - f)
    hist = jnp.concatenate([state.h[None], state.h_hist[:-1]])
    new = OnlineState(h, f, x, hist, state.k + 1)
    new = jax.tree.map(lambda a, b: jnp.where(valid, a, b), new, state)
    eta = jnp.where(valid, eta, 1.0)
    return new, OnlineInfo(
        new.x[0], new.x[1], peak_adhesion(new.x, params.a_s), optimum_creep(new.x), eta, s, hit & valid
    )


@jax.jit
def run(params: OnlineParams, lam, mu, valid, ratio=None) -> tuple[OnlineState, OnlineInfo]:
    """The identifier over ``λ (K,)``, ``μ (K,)``, ``valid (K,)`` (bool) and the forgetting's
    exponents ``ratio (K,)`` (:func:`step_ratios`; ``None``: the paper's per-sample η) with one
    ``lax.scan``; returns the final state and the per-step trace (K, …)."""

    def body(state, obs):
        return step(params, state, obs)

    ratio = jnp.ones(lam.shape, lam.dtype) if ratio is None else ratio
    return lax.scan(body, init(params), (lam, mu, valid, ratio))


@jax.jit
def identify(params: OnlineParams, lam, mu) -> OnlineInfo:
    """Run the identifier over a record ``λ (K,)``, ``μ (K,)`` (every sample used); trace (K, …).

    Pure and jitted: ``jax.vmap(identify, (None, 0, 0))`` batches noise seeds,
    ``jax.vmap(identify, (0, None, None))`` batches coefficient sets.
    """
    return run(params, lam, mu, jnp.ones(lam.shape, bool))[1]


#: Smallest reciprocal condition number ``λ_min/λ_max`` of the final H graded well-conditioned.
MIN_RCOND = 1e-10


def final_status(state: OnlineState):
    """``CONVERGED`` when the run ended with finite estimates and a finite information matrix whose
    reciprocal condition number is at least :data:`MIN_RCOND`; ``NONFINITE`` when anything is
    non-finite; ``SINGULAR`` otherwise (too little excitation: e.g. constant creep, or no
    informative sample at all). An int32 code (jit/vmap friendly)."""
    finite = jnp.all(jnp.isfinite(state.h)) & jnp.all(jnp.isfinite(state.x))
    ev = jnp.linalg.eigvalsh(jnp.where(finite, state.h, 0.0))
    well = (ev[0] > 0) & (ev[0] >= MIN_RCOND * ev[-1])
    return jnp.where(~finite, Status.NONFINITE, jnp.where(well, Status.CONVERGED, Status.SINGULAR)).astype(
        jnp.int32
    )


#: A hold of the SNR step at least this long [s] is reported (:func:`hold_warning`). Algorithm 1
#: on 17 recordings (our dry, wet and sand, 3 each; the independent generator's 4 steady runs and
#: 4 starts, mild sensors): the step held to the end on 6 (every dry run, from its macro-slip
#: excursion at 14 s; 3 of the independent 8, for 11–41 s), once for 8 s before the end, and
#: otherwise for at most 0.1 s.
HOLD_WARNING_S = 5.0


def longest_hold(hit, used) -> tuple[int, int, int]:
    """``(first, last, count)``: sample indices and length of the longest run of consecutive
    informative samples on which the SNR step set ``η = η_max`` (skipped samples neither break nor
    extend a run); ``(-1, -1, 0)`` when the step never fired."""
    idx = np.flatnonzero(np.asarray(used, bool))
    run = longest_run(np.asarray(hit, bool)[idx])
    if run is None:
        return -1, -1, 0
    start, stop = run
    return int(idx[start]), int(idx[stop - 1]), stop - start


def hold_warning(tracked, time) -> dict | None:
    """The ``snr_hold`` warning of a :class:`Tracked` run when the SNR step (eqs 10–17) held
    ``η = η_max`` for :data:`HOLD_WARNING_S` or longer of ``time`` [s] (``None``: samples at
    :data:`REFERENCE_STEP_S`), else ``None`` (also for a
    guarded step, finite ``hold_error``: its holds end when the data disagree). With
    ``η_max = 1`` such a hold can be absorbing: without forgetting ``H`` stops changing, so the
    SNR matrix stays inside the interval ``[a, b]`` (fixed in units of ``H``, not calibrated on
    this recording) and the estimate stops following the data — a rail change there goes
    untracked."""
    used = np.asarray(tracked.used, bool)
    first, last, count = longest_hold(tracked.trace.snr_hit, used)
    if time is None:  # no clock: the samples at the reference step
        held, where = (last - first) * REFERENCE_STEP_S, f"samples {first}–{last}"
    else:
        time = np.asarray(time, float)
        held, where = time[last] - time[first], on_clock((time[first], time[last]), time[0])
    if np.isfinite(tracked.params.hold_error) or count == 0 or held < HOLD_WARNING_S:
        return None
    to_end = not np.any(used[last + 1 :])
    return {
        "code": "snr_hold",
        "params": ["p1", "p2"],
        "message": f"the SNR step held the forgetting factor at eta_max over "
        f"{where}{' (to the end)' if to_end else ''} "
        f"({count} samples): the estimate stopped following the data there, and a change "
        "of rail in that stretch would not be tracked; algorithm 1-guarded ends such a hold, "
        "2 and rls have no SNR step",
        "from_s": float(time[first]),
        "to_s": float(time[last]),
        "samples": count,
        "to_end": bool(to_end),
    }


def optimum_warning(tracked) -> dict | None:
    """The ``no_optimum`` warning when a :class:`Tracked` run ends with ``p2 ≤ 0``: Kiencke's
    curve then has no peak, so the final ``creep_opt`` is none and ``mu_max`` is the ``p2 = 0``
    value ``a_s / p1`` (the data lately did not reach far enough up the curve to place its peak:
    creep far below the optimum), else ``None``."""
    p2 = float(tracked.trace.p2[-1])
    if p2 > 0:
        return None
    return {
        "code": "no_optimum",
        "params": ["p2", "mu_max", "creep_opt"],
        "message": f"the run ends with p2 = {p2:.4g} <= 0: the tracked curve has no peak, so "
        "creep_opt is none and mu_max is its p2 = 0 value a_s/p1; the last stretch of data does "
        "not reach far enough up the curve to place the peak",
    }


def extrapolated_warning(tracked, creep) -> dict | None:
    """``peak_extrapolated`` (:func:`.peak.extrapolation_warning`) when the run's final
    ``creep_opt`` lies outside the ``|creep|`` [-] of its used samples (``creep`` (n,), the
    tracked dataset's): the tracked peak is then Kiencke's extrapolation, not data. ``None``
    otherwise and for a run without a peak (:func:`optimum_warning`)."""
    creep_opt = float(tracked.trace.creep_opt[-1])
    used = np.abs(np.asarray(creep, float))[np.asarray(tracked.used, bool)]
    if not (np.isfinite(creep_opt) and used.size):
        return None
    return extrapolation_warning(creep_opt, float(used.min()), float(used.max()))


#: A tracked peak below this share of the run's high adhesion (:func:`below_data_warning`) is not a
#: peak of the data; the share leaves room for a run whose top samples lie past the peak.
BELOW_DATA_SHARE = 0.8
#: The run's high adhesion: this quantile of the used ``|μ̂|`` (robust to a few outliers) ...
HIGH_QUANTILE = 0.95
#: ... less this many of μ̂'s white-noise sd (:func:`noise_sd`), which lifts the quantile.
HIGH_NOISE_SDS = 2.0


def below_data_warning(tracked, adhesion, time) -> dict | None:
    """``peak_below_data`` when the run's final ``mu_max`` is not positive or lies below
    :data:`BELOW_DATA_SHARE` × the run's high adhesion: the :data:`HIGH_QUANTILE` quantile of
    ``|adhesion|`` [-] (μ̂, (n,)) on its used samples less :data:`HIGH_NOISE_SDS` noise sd. A curve
    whose peak lies below adhesion the run showed is not the curve of that stretch: either the
    rail changed (the message says when the run last showed it, ``time`` [s] (n,), or the sample
    when ``None``) or the tracker forgot the peak in a stretch low on the curve. Algorithm 1 on
    the independent generator's clean runs (4 steady runs and 4 starts at 25–200 Hz, mild sensors;
    4 steady, 4 starts and 4 sweeps at 50 Hz, realistic sensors; 44 finals): it fires on the 19
    finals 27–87 % below the true peak and on none of the 25 within 14 %. The median ``|μ̂|`` as
    the level (until 2026-12) fired on 8 of those 19: a sweep that ended 30 s at μ̂ ≈ 0.025 with
    mu_max 0.079 after showing 0.2 went unwarned. ``None`` otherwise."""
    mu_max = float(tracked.trace.mu_max[-1])
    used = np.asarray(tracked.used, bool)
    mu = np.abs(np.asarray(adhesion, float))
    if not used.any():
        return None
    level = float(np.quantile(mu[used], HIGH_QUANTILE)) - HIGH_NOISE_SDS * float(noise_sd(adhesion, used))
    if mu_max > BELOW_DATA_SHARE * level:
        return None
    k = int(np.flatnonzero(used & (mu >= level))[-1])
    last = f"sample {k}" if time is None else on_clock((float(time[k]),), float(time[0]))
    return {
        "code": "peak_below_data",
        "params": ["mu_max"],
        "message": f"the run ends with mu_max = {mu_max:.3g}, below {BELOW_DATA_SHARE:g} × the "
        f"adhesion {level:.3g} it showed (last at {last}): the tracked curve at the end is "
        "not that stretch's — the rail changed there, or the run lately stayed too low on the curve "
        "to hold the peak (the forgetting dropped it); compare --algorithm 2 or fit --model kiencke",
        "level": level,
        "last_at_s": float(time[k]) if time is not None else None,
    }


def few_samples_warning(tracked) -> dict | None:
    """``few_samples`` when the run used fewer than :data:`.polach_fit.RECOMMENDED_SAMPLES`
    samples (``fit`` says the same of its own): a curve tracked on a handful of samples is rough,
    whatever its status (11 samples ended at mu_max 1.93, 'converged'). ``None`` otherwise."""
    n = int(np.sum(np.asarray(tracked.used, bool)))
    if n >= RECOMMENDED_SAMPLES:
        return None
    return {
        "code": "few_samples",
        "params": ["p1", "p2", "mu_max", "creep_opt"],
        "message": f"{n} samples tracked (< {RECOMMENDED_SAMPLES} recommended): the final curve and "
        "its peak are rough",
    }


def singular_warning(tracked) -> dict | None:
    """``not_converged`` for a run whose status is ``SINGULAR`` (:func:`final_status`: too little
    excitation, e.g. constant creep): ``p1`` and ``p2`` are then not separately determined."""
    if int(tracked.status) != int(Status.SINGULAR):
        return None
    return {
        "code": "not_converged",
        "params": ["p1", "p2", "mu_max", "creep_opt"],
        "message": "status singular: the data excite too little of the curve (the creep hardly "
        "varies), so p1 and p2, and the peak, are not separately determined",
    }


#: Algorithm 1-guarded's hold limit, in the recording's adhesion noise sd (:func:`noise_sd`).
HOLD_SIGMAS = 3.0


def algorithm1_guarded_params(noise_sd, **kw) -> OnlineParams:
    """Algorithm 1 whose SNR step holds ``η = η_max`` only while the prediction error
    ``|μ̂ − μ| ≤`` :data:`HOLD_SIGMAS` · ``noise_sd`` [-]: a hold ends when the data stop agreeing
    with the estimate (a rail change that moves μ̂ by more than that), unlike Algorithm 1's, which
    can hold for good (:func:`hold_warning`)."""
    return algorithm1_params(**{"hold_error": HOLD_SIGMAS * noise_sd, **kw})


def noise_sd(mu, used) -> jax.Array:
    """The white-noise sd [-] of the observed adhesion ``mu`` on the informative samples ``used``
    (:func:`jadhesion.data.creep_state.difference_sd`: third differences, robust). Not the offline
    fit's residual: a rail change inflates that, and the guard would then hold through it."""
    return difference_sd(jnp.asarray(mu)[np.asarray(used, bool)])


#: The identifiers offered on recordings: the paper's two algorithms, Algorithm 1 with a guarded
#: SNR step, and a classic RLS (λ = 0.98).
ALGORITHMS = {
    "1": algorithm1_params,
    "1-guarded": algorithm1_guarded_params,
    "2": algorithm2_params,
    "rls": rls_params,
}
#: Those whose coefficients need the recording's noise sd (``noise_sd=``).
NOISE_CALIBRATED = ("1-guarded",)


class Tracked(NamedTuple):
    """Online identification of one dataset: ``a_s`` used [-], the trace (K, …, NumPy), ``used``
    (K,) informative-sample flags (NumPy), the final :class:`Status` code, the offline fit that gave ``a_s``
    (``None`` when ``a_s`` was given), the coefficients used, and what the forgetting's memory
    was counted in (:data:`FORGETTING`)."""

    a_s: jax.Array
    trace: OnlineInfo
    used: jax.Array
    status: jax.Array
    slope_fit: object
    params: OnlineParams
    forgetting: str


def track_dataset(data: PolachDataset, algorithm: str = "1", a_s=None, key=None, time=None) -> Tracked:
    """Paper 000's identification on a dataset (creep λ, observed μ̂), sample by sample.

    ``algorithm``: a key of :data:`ALGORITHMS` (default coefficients; ``"1-guarded"``'s hold
    limit from μ̂'s noise on the informative samples, :func:`noise_sd`).
    Samples that are not informative (:func:`.kiencke_fit.informative`: standstill ``|v| < 0.1``
    m/s, coasting ``|μ̂| < 0.02``, non-finite) are skipped. ``a_s`` [-]: when ``None`` it is
    estimated from the data as the initial slope of Kiencke's curve fitted offline with ``p1, p2``
    by global LM on the informative samples (:func:`.kiencke_fit.fit_kiencke`, ``key``).
    Status ``NOT_RUN`` with fewer than :data:`.kiencke_fit.MIN_SAMPLES` informative samples.
    ``time`` [s] (n,): the samples' times, so that the forgetting's memory is counted in seconds
    (:func:`step_ratios`); ``None``: per sample, the paper's.
    """
    if algorithm not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algorithm!r}; choose one of {', '.join(ALGORITHMS)}")
    n = data.adhesion.shape[0]
    data = _padded(data)
    used = informative(data) > 0
    slope_fit = None
    if a_s is None:
        slope_fit = fit_kiencke(data, "lm", key)
        a_s = slope_fit.params[2]
    extra = {"noise_sd": noise_sd(data.adhesion, used)} if algorithm in NOISE_CALIBRATED else {}
    params = ALGORITHMS[algorithm](a_s=a_s, **extra)
    ratio = None
    if time is not None:
        ratio = np.pad(step_ratios(time), (0, data.adhesion.shape[0] - n), mode="edge")
        ratio = jnp.asarray(ratio, data.creep.dtype)
    state, trace = run(params, data.creep, data.adhesion, used, ratio)
    status = jnp.where(jnp.sum(used) < MIN_SAMPLES, Status.NOT_RUN, final_status(state))
    forgetting = FORGETTING[time is None]
    trace = OnlineInfo(*(np.asarray(a)[:n] for a in trace))
    used = np.asarray(used)[:n]
    return Tracked(params.a_s, trace, used, status.astype(jnp.int32), slope_fit, params, forgetting)


def _padded(data: PolachDataset) -> PolachDataset:
    """``data`` padded to its length bucket (:func:`.batch_fit.pad_dataset`), its own ``weight``
    (if any) kept on its rows: the tracker skips the padding (its state is unchanged on a sample
    it does not use) and the offline fit ignores it, so every length of a bucket runs the
    bucket's compiled programs."""
    n = data.adhesion.shape[0]
    padded = pad_dataset(data._replace(weight=None))
    if data.weight is None:
        return padded
    weight = np.zeros(padded.adhesion.shape[0], np.asarray(data.weight).dtype)
    weight[:n] = np.asarray(data.weight)
    return padded._replace(weight=jnp.asarray(weight))
