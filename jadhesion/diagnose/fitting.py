"""Joint LM fits of the extended models, vmapped over candidates × cross-validation folds.

Held-out error is measured by blocked cross-validation in time: the recording is cut into
``N_FOLDS`` contiguous blocks; fold k fits on the other blocks (zero weight on block k) and predicts
block k. Contiguous blocks keep autocorrelated neighbours out of the training set, so the held-out
error is honest for slowly varying effects. A parameter that places an effect in time (the rail
change's ``u_change``, :attr:`~jadhesion.models.effect_spec.Param.fold_fixed`) is kept at the
full-data fit in the folds: the fold holding out the change cannot place it, and on that flat
direction its LM stalled or ran to the step cap. Where a fold's training samples all lie on one
side of that time (the change in the first or last block, held out), the effect's size is kept
too: the fold cannot size a step it sees one side of (its drop, traded against μ0, had run to the
bound: held-out error 40× the base's on a clean recording's spurious change at 97 % of the run).
Every fit uses the project's one bounded LM, :func:`jadhesion.identify.lm.box_lm` (projected LM,
MINPACK convergence tests), run to its convergence test with :data:`MAX_STEPS` /
:data:`MAX_STEPS_FOLD` as caps, and every fit carries its :class:`jadhesion.status.Status` code
(:attr:`FitTable.status`).

Compilation: a diagnosis compiles :func:`fit_candidates` **once** per padded length. Recordings
are padded (edge values, zero weight) to a multiple of :data:`PAD_BLOCK` samples
(:func:`pad_signals`); every candidate row has the same number of free parameters
(:data:`WIDTH`, unused slots point at a dummy entry); the base fit, round 1 and round 2 all go
through the same program with :data:`N_CANDIDATES` rows.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..identify.lm import BoxLMOptions, box_lm
from ..identify.slip_law import node_moments, node_slips
from ..models.kinematics import creepage
from ..models.polach import PARAM_NAMES, polach_adhesion
from ..status import Status
from . import extensions as ext
from .signals import Signals

N_FOLDS = 5
#: LM step caps (full-data fit; folds warm-start from it) and tolerances. A cap is a cap: a fit
#: stops at its convergence test (relative cost change ≤ FTOL with a step ≤ XTOL, or a projected
#: gradient ≤ GTOL); one that reaches the cap is reported as ``max_steps``, never ranked. The folds
#: get the full fit's cap: at 100, rail-change folds (the step's size refitted with its time held)
#: stopped at the cap on recordings where they converge in 100–200 steps, and so went untested.
#: At 200 the independent generator's +21 % rail change at 20 Hz (seed 300023) stopped at the cap
#: from every start near its time (SSE −90 %; converged in 354 steps) and a converged start at the
#: recording's edge (SSE −0 %) stood for it; a thermal softening (300028) converged in 401.
MAX_STEPS, MAX_STEPS_FOLD = 500, 500
#: Smallest noise sd [-] of the target in :func:`eiv_weights` (noise-free recordings).
MIN_TARGET_SD = 1e-6
OPTIONS = BoxLMOptions(ftol=1e-9, xtol=1e-7, gtol=1e-10)
#: Rows of every :func:`fit_candidates` call (base + 7 effects + 2 extra radius starts + 3 extra
#: rail-change times) and free parameters per row (the Polach five + at most four extras: rail
#: change with load transfer).
N_CANDIDATES = 13
WIDTH = 9
#: Recordings are padded to a multiple of this many samples (one compiled program per multiple).
PAD_BLOCK = 1000
#: Base-fit starts: a fixed space-filling design — the first :data:`N_SCREEN` points of the
#: 5-D Halton sequence (bases 2, 3, 5, 7, 11; leaped past the origin) over the box ``[0, 1]⁵``
#: of ``[kA, kS, mu0, A, B]`` — screened by their SSE on the recording; the best
#: :data:`N_CANDIDATES` start LM runs and the lowest-SSE result is kept. Nothing in it depends
#: on the simulated scenarios (the paper's identified sets are *not* among the starts).
N_SCREEN = 128
#: Polach parameters whose upper edge in the identification box ([0, 1], DESIGN §1) :func:`fit_truth`
#: lets the null's curve pass: ``mu0``, the curve's scale (with ``kS = 0`` the curve peaks at μ0/π,
#: so a peak of 0.35 needs μ0 = 1.10), for which rail change, load transfer, torque offset and
#: thermal softening can each stand in past the edge. (``kA``, ``kS`` and ``A = mu_inf/mu0`` are at
#: most 1 by Polach's definitions; ``B`` sits at its edge on half of our simulator's clean
#: recordings, where no candidate took it up.)
OPEN_ABOVE = ("mu0",)
#: Their upper bound in :func:`fit_truth`, in units of the box's edge: no constraint in effect,
#: finite only because box LM works in coordinates normalised to the box.
OPEN_FACTOR = 10.0
#: The superset vector gets one unused slot, so candidates with fewer free parameters than
#: :data:`WIDTH` pad their index list with it.
PAD = ext.N_PARAMS
_LO = np.concatenate([ext.BOUNDS[0], [-1.0]])
#: Upper bounds (P + 1,) of the box. The in-sample fits (:func:`fit_base`, the null's replicas,
#: :func:`fit_truth`) pass their upper bounds explicitly, so they share one compiled program.
UPPER = np.concatenate([ext.BOUNDS[1], [1.0]])
_FOLD_FIXED = np.concatenate([ext.FOLD_FIXED, [False]])
_PLACED = np.concatenate([ext.PLACED, [False]])


def halton(n: int, dim: int = 5, skip: int = 1) -> np.ndarray:
    """First ``n`` points (after ``skip``) of the Halton sequence in ``[0, 1)^dim``."""
    primes = [2, 3, 5, 7, 11, 13, 17, 19][:dim]
    out = np.zeros((n, dim))
    for j, p in enumerate(primes):
        for i in range(n):
            k, f, x = i + skip, 1.0, 0.0
            while k > 0:
                f /= p
                x += f * (k % p)
                k //= p
            out[i, j] = x
    return out


BASE_STARTS = halton(N_SCREEN)


class FitTable(NamedTuple):
    """Fits of C candidates: ``params`` (C, P) on all data, ``mae``/``sse`` (C,) in-sample,
    ``heldout_mae`` (C,) blocked-CV (``mae`` and ``heldout_mae`` both means of ``weight · |target −
    prediction|`` over the selected samples; the weights have mean 1 there, :func:`eiv_weights`),
    ``residual`` (C, n) of the full-data fit (zero on padding), ``status`` (C,) int32
    :class:`~jadhesion.status.Status` of the full-data fit, ``fold_status`` (C,) the worst status
    among its cross-validation fits, ``steps`` (C,) LM steps of the full fit, ``fold_params``
    (C, N_FOLDS, P) the cross-validation fits' parameters (NaN without folds)."""

    params: jax.Array
    mae: jax.Array
    sse: jax.Array
    heldout_mae: jax.Array
    residual: jax.Array
    status: jax.Array
    fold_status: jax.Array
    steps: jax.Array
    fold_params: jax.Array


def fold_weights(n: int, n_folds: int = N_FOLDS, n_total=None, weight=None) -> jax.Array:
    """(n_folds + 1, n_total) weights: row 0 one on the ``n`` valid samples (times ``weight``,
    the selection); row k + 1 also zero on contiguous block k. Samples from ``n`` to ``n_total``
    (padding) are zero in every row."""
    n_total = n if n_total is None else n_total
    i = jnp.arange(n_total)
    valid = (i < n).astype(float) * (1.0 if weight is None else weight)
    block = jnp.minimum(i * n_folds // n, n_folds - 1)
    rows = [valid] + [(block != k).astype(float) * valid for k in range(n_folds)]
    return jnp.stack(rows)


def padded_length(n: int) -> int:
    """The length a recording of ``n`` samples is padded to."""
    return int(-(-n // PAD_BLOCK) * PAD_BLOCK)


def pad_signals(sig: Signals) -> Signals:
    """``sig`` with its (n,) arrays extended by their last value to :func:`padded_length` (the
    weight by zeros)."""
    n = sig.time.shape[0]
    extra = padded_length(n) - n
    padded = jax.tree_util.tree_map(
        lambda x: np.pad(np.asarray(x), (0, extra), mode="edge") if np.ndim(x) == 1 else x, sig
    )
    return padded._replace(weight=np.pad(np.asarray(sig.weight), (0, extra)))


def free_indices(names, width: int = WIDTH):
    """Indices of the Polach five and the extras of ``names`` in the padded superset vector."""
    idx = list(range(5)) + [
        5 + ext.EXTRA_NAMES.index(p) for e in ext.EFFECTS if e.name in names for p in e.params
    ]
    if len(idx) > width:
        raise ValueError(f"{names} need {len(idx)} free parameters, more than {width}")
    return idx + [PAD] * (width - len(idx))


def _free_residual(z, args):
    full, idx, active, weights, sig = args
    return ext.residual(full.at[idx].set(z)[:PAD], (active, weights, sig))


def status_code(result, max_steps: int):
    """int32 :class:`~jadhesion.status.Status` of a :class:`~jadhesion.identify.lm.LMResult`."""
    finite = jnp.isfinite(result.sse) & jnp.all(jnp.isfinite(result.params))
    return jnp.where(
        ~finite,
        int(Status.NONFINITE),
        jnp.where(
            result.success,
            int(Status.CONVERGED),
            jnp.where(result.steps >= max_steps, int(Status.MAX_STEPS), int(Status.STALLED)),
        ),
    )


def _solve(full, idx, active, weights, sig, max_steps, upper):
    """Projected LM over the free entries ``idx`` of ``full`` (P + 1,) within ``[_LO, upper]``;
    returns the updated ``full``, the fit's status code and its steps."""
    lo, hi = jnp.asarray(_LO)[idx], upper[idx]
    result = box_lm(
        _free_residual,
        jnp.clip(full[idx], lo, hi),
        (full, idx, active, weights, sig),
        (lo, hi),
        OPTIONS,
        max_steps=max_steps,
    )
    return full.at[idx].set(result.params), status_code(result, max_steps), result.steps


def _pad(p):
    return jnp.concatenate([p, jnp.zeros(p.shape[:-1] + (1,))], axis=-1)


@jax.jit
def screen_starts(sig: Signals, n_valid) -> jax.Array:
    """SSE of the plain Polach model at each :data:`BASE_STARTS` point, shape (N_SCREEN,)."""
    slip = sig.wheel_speed - sig.speed
    creep = creepage(slip, sig.speed)
    valid = (jnp.arange(sig.time.shape[0]) < n_valid) & (sig.weight > 0)
    sse = jax.lax.map(
        lambda th: jnp.sum(
            jnp.where(valid, (sig.adhesion - polach_adhesion(th, creep, slip, sig.k_eps)) ** 2, 0.0)
        ),
        jnp.asarray(BASE_STARTS),
    )
    return jnp.where(jnp.isfinite(sse), sse, jnp.inf)


def base_rows(sig: Signals, n_valid: int) -> tuple:
    """Starts (C, P), free indices (C, WIDTH) and masks (C, N_EXTRA) for the plain-Polach fit from
    the :data:`N_CANDIDATES` best-screened :data:`BASE_STARTS`."""
    best = np.argsort(np.asarray(screen_starts(sig, n_valid)))[:N_CANDIDATES]
    starts = np.column_stack([BASE_STARTS[best], np.tile(ext.NEUTRAL, (N_CANDIDATES, 1))])
    idx = np.tile(np.array(free_indices(())), (N_CANDIDATES, 1))
    return starts, idx, np.zeros((N_CANDIDATES, ext.N_EXTRA), bool)


@functools.partial(jax.jit, static_argnames="folds")
def fit_candidates(p0, idx, actives, sig: Signals, n_valid, folds: bool = True, upper=UPPER) -> FitTable:
    """Fit every candidate — free indices ``idx`` (C, K), effect masks ``actives`` (C, N_EXTRA),
    starts ``p0`` (C, P) — on the weighted first ``n_valid`` samples of the (padded) recording,
    then (``folds``) on each CV fold warm-started from that fit; evaluate in-sample and held-out
    errors (``heldout_mae`` NaN and ``fold_status`` converged without folds). ``upper`` (P + 1,):
    the upper bounds (:data:`UPPER`, or :func:`fit_truth`'s: given explicitly, the same program).

    Candidates and folds are solved one after another (:func:`jax.lax.map`): each LM stops at its
    own convergence test, and memory is that of one fit (linear in the samples)."""
    n = sig.time.shape[0]
    weights = fold_weights(n_valid, N_FOLDS, n, sig.weight)
    used = jnp.sum(weights[0])
    upper = jnp.asarray(upper)

    def resid(p, a):
        target, pred = ext.predict(p[:PAD], a, sig)
        return (target - pred) * weights[0]

    def one(row):
        p, i, a = row
        full, status, steps = _solve(_pad(p), i, a, weights[0], sig, MAX_STEPS, upper)
        r_full = resid(full, a)
        if not folds:
            none = jnp.full((N_FOLDS, full.shape[0]), jnp.nan)
            return full, status, steps, r_full, jnp.nan, jnp.int32(int(Status.CONVERGED)), none

        i_fold = jnp.where(jnp.asarray(_FOLD_FIXED)[i], PAD, i)  # a change time stays put
        t_change = ext.change_time(full[ext.U_CHANGE], sig)

        def fold(w):
            train = w > 0
            one_side = jnp.all(~train | (sig.time < t_change)) | jnp.all(~train | (sig.time > t_change))
            i_k = jnp.where(one_side & jnp.asarray(_PLACED)[i], PAD, i_fold)  # nor sized from one side
            pk, sk, _ = _solve(full, i_k, a, w, sig, MAX_STEPS_FOLD, upper)
            return jnp.sum(jnp.where(w > 0, 0.0, jnp.abs(resid(pk, a)))), sk, pk  # block k, weighted once

        held, fold_status, fold_full = jax.lax.map(fold, weights[1:])
        return full, status, steps, r_full, jnp.sum(held) / used, jnp.max(fold_status), fold_full

    full, status, steps, r_full, heldout, fold_status, fold_full = jax.lax.map(one, (p0, idx, actives))
    sse = jnp.sum(r_full**2, axis=1)
    return FitTable(
        full[:, :PAD],
        jnp.sum(jnp.abs(r_full), axis=1) / used,
        jnp.where(jnp.isfinite(sse), sse, jnp.inf),
        heldout,
        r_full,
        status,
        fold_status,
        steps,
        fold_full[:, :, :PAD],
    )


@jax.jit
def slip_variance(params, sig: Signals) -> jax.Array:
    """``Var[μ(w)]`` (n,) [-²] of the plain model at ``params`` over the true slip's law ``w``
    (:func:`jadhesion.identify.slip_law.node_slips`: ``N(ŵ, sd²)`` truncated to the force's side),
    by :data:`~jadhesion.identify.slip_law.GH_NODES`-node Gauss–Hermite quadrature, the variance of
    the fits' likelihood (:func:`jadhesion.identify.likelihood.curve_moments`). On the curve's
    straight parts it is ``(∂μ/∂w)² sd²``; where ``sd`` spans the curve's bend, at walking pace
    above all (creep ``w/v``), it is the spread of the curve over that span, which the slope at
    one point misses."""
    none = jnp.zeros(ext.N_EXTRA, bool)
    nodes = node_slips(sig.wheel_speed - sig.speed, sig.slip_sd, sig.adhesion)
    exact = sig._replace(slip_sd=jnp.zeros_like(sig.slip_sd))

    def curve(w):
        return ext.predict(params, none, exact._replace(wheel_speed=sig.speed + w))[1]

    return node_moments(jax.vmap(curve)(nodes))[1]


def eiv_weights(params, sig: Signals, target_sd: float) -> np.ndarray:
    """Errors-in-variables weights (n,) of the fits' residuals: ``1/√(σ_μ² + Var[μ(w)])``
    (Orear's effective variance, with the curve's variance over the slip's law by quadrature,
    :func:`slip_variance`, as LM's second stage in
    :func:`jadhesion.identify.polach_residuals.polach_lm_residual`), ``sd = sig.slip_sd`` [m/s] the
    smoother's, ``σ_μ = target_sd`` [-] (at least :data:`MIN_TARGET_SD`); times ``sig.weight`` and
    normalised to mean 1 over the selected samples. On the steep initial slope a slip error of a
    few mm/s moves the curve by more than the target's noise, so those samples count for less.
    Unweighted, an attenuated slope plus a torque offset or a radius error fitted clean recordings
    of the independent generator far better than Polach alone (in-sample SSE reductions 0.68–0.94
    on 6 of its first 14 clean recordings, seed 11). Linearised (``(∂μ/∂w)² sd²`` at the smoothed
    slip), the weights missed walking pace: there a slip error of ``sd`` is a creep error of
    ``sd/v``, which spans the whole micro-slip region, while the slope at a smoothed slip in
    saturation is ~0; such samples kept full weight, and a rail change "explained" their misfit on
    clean starts of the independent generator (SSE reductions 0.88–0.96). Coloured speed noise,
    which the smoother tracks as motion, is not in ``slip_sd``: an estimate of it from the train
    dynamics read 18 mm/s on our simulator (whose vehicle speed does not follow that model) and
    weighted real effects out of the fits."""
    var_mu = np.asarray(slip_variance(jnp.asarray(params), sig))
    sd_mu = max(float(target_sd), MIN_TARGET_SD)
    w = np.asarray(sig.weight) / np.sqrt(sd_mu**2 + var_mu)
    return w / np.mean(w[np.asarray(sig.weight) > 0])


def fit_base(sig: Signals, n_valid=None) -> tuple:
    """Best LM fit of the plain Polach model from the screened :data:`BASE_STARTS`, through
    :func:`fit_candidates` (no extra compilation): ``(params (P,), Status)``. The lowest-SSE
    *converged* start wins; only when no start converged is the lowest-SSE one returned, with its
    status."""
    n_valid = sig.time.shape[0] if n_valid is None else n_valid
    starts, idx, actives = base_rows(sig, n_valid)
    table = fit_candidates(starts, idx, actives, sig, n_valid, folds=False, upper=UPPER)
    sse, status = np.asarray(table.sse), np.asarray(table.status)
    ok = status == int(Status.CONVERGED)
    i = int(np.argmin(np.where(ok, sse, np.inf))) if ok.any() else int(np.argmin(sse))
    return np.asarray(table.params)[i], Status(int(status[i]))


def fit_truth(sig: Signals, n_valid: int, p_base) -> tuple:
    """``(params (P,), sse_reduction)``: the curve the null's replicas are re-synthesised from. When
    the base fit ``p_base`` sits at the box's upper edge in a parameter of :data:`OPEN_ABOVE`, the
    plain Polach fit with those parameters free above it (to :data:`OPEN_FACTOR` × the edge; the
    screened starts and ``p_base``), if it converged and lowers the weighted SSE, with its relative
    SSE reduction against ``p_base``; otherwise ``(p_base, 0.0)``. A curve beyond the box (the
    identification box, DESIGN §1) is misfit the base model keeps on the recording; replicas
    re-synthesised from the boxed fit lack it, so candidates that scale μ past the edge (a rail
    change at the recording's start, load transfer by a steady deceleration, a torque offset,
    thermal "hardening") took it up against a null that never showed it (issue #15: a clean braking
    recording with μ = 0.7x/(1 + x²), i.e. Polach with μ0 = 0.35π, kS = 0, A = 1)."""
    p_base = np.asarray(p_base, float)
    edge = np.array([PARAM_NAMES.index(k) for k in OPEN_ABOVE])
    if not np.any(p_base[edge] >= UPPER[edge]):
        return p_base, 0.0
    upper = UPPER.copy()
    upper[edge] *= OPEN_FACTOR
    starts, idx, actives = base_rows(sig, n_valid)
    starts[-1] = p_base
    table = fit_candidates(starts, idx, actives, sig, n_valid, folds=False, upper=upper)
    sse = np.where(np.asarray(table.status) == int(Status.CONVERGED), np.asarray(table.sse), np.inf)
    weights = fold_weights(n_valid, N_FOLDS, sig.time.shape[0], sig.weight)[0]
    sse0 = float(jnp.sum(ext.residual(jnp.asarray(p_base), (actives[0], weights, sig)) ** 2))
    i = int(np.argmin(sse))
    if not sse[i] < sse0:
        return p_base, 0.0
    return np.asarray(table.params)[i], float(1.0 - sse[i] / sse0)
