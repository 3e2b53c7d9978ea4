"""The ``mcmc`` row of the paper's Table 2 comparison (paper-experiment code, not the library's).

The posterior itself is :func:`jadhesion.identify.mcmc.sample_posterior`; this module turns one run
into the costs and errors that :mod:`jadhesion.experiments.table2` lists beside the optimisers.
"""

from __future__ import annotations

import warnings
from typing import Optional

import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..identify.ensemble import MIN_TAU_MULTIPLE, ChainTooShortWarning
from ..identify.likelihood import ObserverTerms
from ..identify.mcmc import sample_posterior
from ..identify.polach_fit import polach_mae
from ..models.polach import PARAM_NAMES


def table2_row(
    data: PolachDataset,
    theta0,
    *,
    walkers: int = 32,
    steps: int = 5000,
    seed: int = 0,
    likelihood: str = "gauss",
    obs: Optional[ObserverTerms] = None,
    spread=1e-3,
    burn: Optional[int] = None,
    truth=None,
) -> dict:
    """The ``mcmc`` row of a Table-2-style comparison for one dataset.

    ``error``: MAE (the paper's fitness, eq 15, against ``mu_hat``) of the posterior-median
    parameters; ``steps`` / ``evaluations`` / ``seconds``: what a converged chain costs — burn-in
    plus ``50 τ_max`` steps, seconds scaled from this run's warm wall time (``converged``: this run
    was already that long; otherwise τ comes from a shorter chain and the cost is an estimate);
    ``width90``: 90 % interval widths of the parameters and derived quantities; with ``truth``,
    ``param_abs_error`` |median − truth|.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ChainTooShortWarning)
        result = sample_posterior(
            data,
            theta0,
            walkers=walkers,
            steps=steps,
            seed=seed,
            likelihood=likelihood,
            obs=obs,
            spread=spread,
            burn=burn,
        )
    d = result.diagnostics
    median = np.array([result.params[n]["median"] for n in PARAM_NAMES])
    needed = int(np.ceil(d.burn + MIN_TAU_MULTIPLE * np.max(d.tau) * d.thin))
    row = {
        "method": "mcmc",
        "likelihood": likelihood,
        "error": float(polach_mae(jnp.asarray(median), data)),
        "params": dict(zip(PARAM_NAMES, median.tolist())),
        "steps": needed,
        "evaluations": needed * walkers,
        "seconds": d.seconds * needed / d.steps,
        "converged": not d.warnings,
        "steps_run": d.steps,
        "seconds_run": d.seconds,
        "log_prob_compile_seconds": d.compile_seconds,
        "walkers": walkers,
        "tau_max": float(np.max(d.tau)),
        "acceptance": d.acceptance,
        "width90": {n: q["q95"] - q["q05"] for n, q in {**result.params, **result.derived}.items()},
        "interval90": {n: [q["q05"], q["q95"]] for n, q in {**result.params, **result.derived}.items()},
    }
    if truth is not None:
        truth = np.asarray(truth, float)
        row["param_abs_error"] = dict(zip(PARAM_NAMES, np.abs(median - truth).tolist()))
    return row
