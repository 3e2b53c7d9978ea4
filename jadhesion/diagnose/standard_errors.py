"""Standard errors of the extended model's parameters, so a named effect's size says how far to
trust it.

The larger of two per parameter. The HAC sandwich of the project's one covariance routine
(:func:`jadhesion.identify.uncertainty.covariance`) at the final fit, over the parameters that fit
left free, from the fits' weighted residual ``w·(target − prediction)`` and its Jacobian
(:func:`.sensitivity.linearise`, the program the sensitivity already runs): the noise's share. And
the delete-a-block jackknife over the cross-validation fits (each refitted without one of
:data:`.fitting.N_FOLDS` contiguous blocks, :attr:`.fitting.FitTable.fold_params`),
``√((K − 1)/K · Σ (θ_k − θ̄)²)``: where the model misfits one stretch of the run differently from
another, the estimate moves with the stretches left out, which the sandwich does not see. A
parameter the folds hold at the full fit (a rail change's time; its size where a fold sees one
side of it) has no jackknife spread and keeps the sandwich's. As ``fit``'s trust
report (:mod:`jadhesion.identify.trust`): a parameter within :data:`BOUND_TOL` of a face of its box
stays free in the covariance but gets no standard error (a local interval means nothing there),
and one whose standard error is not :func:`~jadhesion.identify.uncertainty.determined` (infinite,
or wider than its box) gets none either. The errors are conditional on the model: misfit it leaves
is not in them (the benchmarks measure their coverage), and a rail change's time is better read
from its profile interval (:mod:`.change_time`), since the change point is not a regular parameter.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..identify.uncertainty import Z90, block_jackknife_sd, covariance, determined, normal_interval
from ..models.polach import PARAM_NAMES
from . import extensions as ext
from . import fitting
from .sensitivity import linearise

#: Relative distance (of the box's width) within which a parameter counts as on a bound.
BOUND_TOL = 1e-6
_NAMES = tuple(PARAM_NAMES) + tuple(ext.EXTRA_NAMES)


def standard_errors(params, active, effects, sig, n_valid: int, fold_params=None) -> dict:
    """``{"stderr": {name: sd or None}, "ci90": {name: [lo, hi] or None}, "stderr_hac": {...},
    "stderr_jackknife": {...}, "at_bound": [...], "undetermined": [...], "lags": L}`` over the free
    parameters of the model with ``effects`` (fitted ``params`` (N_PARAMS,), masks ``active``
    (N_EXTRA,), cross-validation fits ``fold_params`` (K, N_PARAMS) or None) on the padded
    signals ``sig`` of ``n_valid`` samples. ``stderr`` is the larger of the two; ``ci90`` is
    ``value ± 1.645·stderr`` clipped to the parameter's box."""
    theta, extras = ext.unpack(np.asarray(params, float), np.asarray(active))
    full = np.concatenate([np.asarray(theta), np.array([float(extras[k]) for k in ext.EXTRA_NAMES])])
    r, jac = linearise(jnp.asarray(full), jnp.ones(ext.N_EXTRA, bool), sig)
    w = np.asarray(fitting.fold_weights(n_valid, fitting.N_FOLDS, sig.time.shape[0], sig.weight)[0])
    idx = [i for i in fitting.free_indices(effects) if i != fitting.PAD]
    used = w > 0  # samples left out and padding count for nothing, whatever the model gives there
    cols = np.zeros((w.size, fitting.WIDTH))  # one compiled covariance per padded length
    cols[used, : len(idx)] = np.asarray(jac)[used][:, idx] * w[used, None]
    res = np.where(used, np.asarray(r) * w, 0.0)
    unused = np.arange(fitting.WIDTH) >= len(idx)
    cov, lags = covariance(jnp.asarray(cols), jnp.asarray(res), fixed=unused, weight=jnp.asarray(w))
    hac = np.sqrt(np.diag(np.asarray(cov)))[: len(idx)]
    jack = np.full(len(idx), np.nan)
    if fold_params is not None:
        jack = block_jackknife_sd(np.asarray(fold_params, float)[:, idx])
    sd = np.where(np.isfinite(jack), np.maximum(hac, np.nan_to_num(jack)), hac)
    out = {"stderr": {}, "ci90": {}, "stderr_hac": {}, "stderr_jackknife": {}}
    out.update({"at_bound": [], "undetermined": [], "lags": int(lags)})
    for i, s, h, j in zip(idx, sd, hac, jack, strict=True):
        name, lo, hi = _NAMES[i], float(ext.BOUNDS[0][i]), float(ext.BOUNDS[1][i])
        on_bound = min(full[i] - lo, hi - full[i]) <= BOUND_TOL * (hi - lo)
        ok = not on_bound and determined(s, hi - lo)
        if on_bound:
            out["at_bound"].append(name)
        elif not ok:
            out["undetermined"].append(name)
        out["stderr"][name] = float(s) if ok else None
        out["stderr_hac"][name] = float(h) if np.isfinite(h) else None
        out["stderr_jackknife"][name] = float(j) if np.isfinite(j) else None
        out["ci90"][name] = normal_interval(float(full[i]), float(s), Z90, lo, hi) if ok else None
    return out
