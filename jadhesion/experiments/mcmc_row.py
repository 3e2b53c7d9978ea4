"""The ``mcmc`` row of the paper's Table 2 comparison (paper-experiment code, not the library's).

The posterior itself is :func:`jadhesion.identify.mcmc.sample_posterior`; this module starts it on a
simulated recording (:func:`mcmc_row`) and turns one run into the costs and errors that
:mod:`jadhesion.experiments.table2` lists beside the optimisers (:func:`table2_row`).
"""

from __future__ import annotations

import time
import warnings
from typing import Optional

import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..data.scenarios import get_scenario
from ..identify.ensemble import ChainTooShortWarning, steps_needed
from ..identify.laplace import initial_spread, observer_residual
from ..identify.lm import box_lm
from ..identify.mcmc import sample_posterior
from ..identify.observer_view import ObserverTerms, recording_observer_terms
from ..identify.polach_residuals import polach_mae
from ..models.polach import BOUNDS, PARAM_NAMES
from ..status import Status

#: The mcmc rows: likelihood, ensemble size, steps run (burn-in: a third), fewest steps allowed.
MCMC_LIKELIHOOD = "observer"
MCMC_WALKERS = 32
MCMC_STEPS = 1500
MCMC_MIN_STEPS = 30


def mcmc_row(
    sim, data, theta_lm, *, likelihood=MCMC_LIKELIHOOD, walkers=MCMC_WALKERS, steps=MCMC_STEPS, seed=0
) -> dict:
    """The ``mcmc`` row of one simulated recording ``sim`` (its dataset ``data``), walkers started
    at the LM fit ``theta_lm`` — for the observer likelihood polished by a projected LM on the
    observer's view of the curve (:func:`jadhesion.identify.lm.box_lm`). ``status``:
    ``"converged"`` when the chain ran burn-in + 50 τ_max steps, else ``"max_steps"``."""
    t0 = time.perf_counter()
    obs = None
    theta0 = jnp.asarray(theta_lm)
    if likelihood == "observer":
        obs = recording_observer_terms(sim)
        theta0 = box_lm(observer_residual, theta0, (data, obs), BOUNDS).params
    spread = np.asarray(initial_spread(theta0, data, obs=obs))
    start_seconds = time.perf_counter() - t0
    row = table2_row(
        data,
        np.asarray(theta0),
        walkers=walkers,
        steps=steps,
        seed=seed,
        likelihood=likelihood,
        obs=obs,
        spread=spread,
        burn=steps // 3,
        truth=np.asarray(get_scenario(sim.truth["scenario"]).params),
    )
    row["start_seconds"] = start_seconds
    row["compile_seconds"] = row.pop("log_prob_compile_seconds")
    row["iterations"] = row["steps"]
    row["status"] = (Status.CONVERGED if row["converged"] else Status.MAX_STEPS).label
    return row


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
    ``param_abs_error`` |median − truth|. A chain in which a walker never moved has no τ: then
    ``tau_max``, ``steps``, ``evaluations`` and ``seconds`` are None (no estimate of the cost).
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
    needed = steps_needed(d.tau, d.burn, d.thin)
    mixed = needed is not None
    row = {
        "method": "mcmc",
        "likelihood": likelihood,
        "error": float(polach_mae(jnp.asarray(median), data)),
        "params": dict(zip(PARAM_NAMES, median.tolist(), strict=True)),
        "steps": needed,
        "evaluations": needed * walkers if mixed else None,
        "seconds": d.seconds * needed / d.steps if mixed else None,
        "converged": not d.warnings,
        "steps_run": d.steps,
        "seconds_run": d.seconds,
        "log_prob_compile_seconds": d.compile_seconds,
        "walkers": walkers,
        "tau_max": float(np.max(d.tau)) if mixed else None,
        "acceptance": d.acceptance,
        "width90": {n: q["q95"] - q["q05"] for n, q in {**result.params, **result.derived}.items()},
        "interval90": {n: [q["q05"], q["q95"]] for n, q in {**result.params, **result.derived}.items()},
    }
    if truth is not None:
        truth = np.asarray(truth, float)
        row["param_abs_error"] = dict(zip(PARAM_NAMES, np.abs(median - truth).tolist(), strict=True))
    return row
