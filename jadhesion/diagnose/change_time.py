"""Where a named rail change lies in time: a profile-likelihood interval for its time.

The fit gives one time ``t_c``; where the recording has few informative samples (a steady run at
creeps of 10⁻⁵–10⁻³, where μ0 hardly shows) every time across a long stretch fits as well, and one
number hides that (a 600 s run at 200 Hz of the independent generator: fitted 84.6 s, true 344.9 s).
:func:`interval` fixes ``u_change`` at each of :data:`N_GRID` times across the fit's bounds,
refits every other free parameter of the final model there (the same bounded LM and compiled
program as the fits, :func:`.fitting.fit_candidates`, from the final fit), and keeps the times
whose weighted in-sample SSE passes the likelihood-ratio test

    n_eff · ln(SSE(u) / SSE_min) ≤ χ²₁(LEVEL),

``n_eff = n/κ`` the final fit's residual's effective sample count, ``κ`` its long-run variance
over its variance (:func:`jadhesion.identify.uncertainty.colour_factor`, as in the fits' standard
errors): coloured residuals widen the interval. For a change point χ²₁ is an approximation (the
time is not a regular parameter), and where the residual has structure of its own a step can take
it up at a wrong time (a stretch of samples left out: the profile is flat across it, its edge
sometimes a little better); the benchmarks measure the interval's coverage on both generators.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..identify.uncertainty import colour_factor
from ..status import Status
from . import extensions as ext
from . import fitting

#: Level of the interval and its χ²₁ quantile (scipy.stats.chi2.ppf(0.90, 1)).
LEVEL, CHI2 = 0.90, 2.705543454095404
#: Times on the profile: a multiple of the fits' rows, so each call fills one program.
N_GRID = 3 * fitting.N_CANDIDATES
_U_LO, _U_HI = (float(b[ext.U_CHANGE]) for b in ext.BOUNDS)


def profile(params, effects, sig, n_valid: int) -> tuple:
    """``(u (N_GRID,), sse (N_GRID,), status (N_GRID,) int)``: the final model (``effects``, fitted
    ``params`` (N_PARAMS,)) refitted with the change's time held at each grid point, on the padded
    signals ``sig`` of ``n_valid`` samples."""
    u = np.linspace(_U_LO, _U_HI, N_GRID)
    starts = np.tile(np.asarray(params, float), (N_GRID, 1))
    starts[:, ext.U_CHANGE] = u
    idx = np.array([i if i != ext.U_CHANGE else fitting.PAD for i in fitting.free_indices(effects)])
    actives = np.tile(np.asarray(ext.active_mask(effects)), (fitting.N_CANDIDATES, 1))
    sse, status = [], []
    for k in range(0, N_GRID, fitting.N_CANDIDATES):
        rows = starts[k : k + fitting.N_CANDIDATES]
        table = fitting.fit_candidates(
            rows, np.tile(idx, (len(rows), 1)), actives, sig, n_valid, folds=False, upper=fitting.UPPER
        )
        sse.append(np.asarray(table.sse))
        status.append(np.asarray(table.status))
    return u, np.concatenate(sse), np.concatenate(status)


def interval(params, effects, sig, n_valid: int, residual) -> dict:
    """The change's time as an interval: ``t_change_interval_s`` ``[lo, hi]`` [s] (the hull of the
    grid times that pass the test and of the fitted time where it passes, widened by a grid step
    each side — to the neighbouring grid times, between which the test's boundary lies — and
    clipped to the recording), ``level``, ``grid_step_s``, ``best_t_change_s`` (the lowest-SSE time
    among the fit's and the grid's), ``fit_inside`` (whether the fitted time passes the test: false
    when the profile found a better optimum than the fit's), ``unconverged`` (grid fits left out,
    never counted as inside) and ``n_eff``. ``residual``: the final fit's weighted residual on the
    selected samples, in time order."""
    residual = np.asarray(residual, float)
    sse_fit = float(np.sum(residual**2))
    n_eff = residual.size / float(colour_factor(jnp.asarray(residual))[0])
    u, sse, status = profile(params, effects, sig, n_valid)
    ok = (status == int(Status.CONVERGED)) & np.isfinite(sse)
    u_fit = float(np.asarray(params)[ext.U_CHANGE])
    best = min(sse_fit, float(np.min(sse[ok])) if ok.any() else np.inf)
    inside = ok & (n_eff * np.log(np.maximum(sse, best) / best) <= CHI2)
    fit_inside = bool(n_eff * np.log(max(sse_fit, best) / best) <= CHI2)
    chosen = list(u[inside]) + ([u_fit] if fit_inside else [])
    step = float(u[1] - u[0])  # to the neighbouring grid times, where the test's boundary lies
    best_u = u_fit if best == sse_fit else float(u[ok][np.argmin(sse[ok])])
    return {
        "t_change_interval_s": [
            float(ext.change_time(max(min(chosen) - step, 0.0), sig)),
            float(ext.change_time(min(max(chosen) + step, 1.0), sig)),
        ],
        "level": LEVEL,
        "grid_step_s": step * float(sig.duration),
        "best_t_change_s": float(ext.change_time(best_u, sig)),
        "fit_inside": fit_inside,
        "unconverged": int(np.sum(~ok)),
        "n_eff": n_eff,
    }
