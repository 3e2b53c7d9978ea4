"""Posterior figures: a corner plot of the Polach parameters and a posterior-predictive band over the
data on the adhesion–creep plane."""

from __future__ import annotations

import warnings

import jax.numpy as jnp
import numpy as np
from matplotlib.figure import Figure

from ..data.dataset import PolachDataset
from ..identify.likelihood import STUDENT_NU
from ..identify.mcmc import PosteriorResult, posterior_curves

_LABELS = {
    "kA": r"$k_A$",
    "kS": r"$k_S$",
    "mu0": r"$\mu_0$",
    "A": r"$A$",
    "B": r"$B$ [s/m]",
    "sigma": r"$\sigma$",
    "b": r"$b$",
    "rho": r"$\rho$",
}


def corner_plot(result: PosteriorResult, truths=None) -> Figure:
    """Corner plot of all sampled coordinates with 5/50/95 % quantile lines (``truths``: optional
    true values, same order as ``result.names``, ``None`` entries allowed)."""
    with warnings.catch_warnings():  # corner imports arviz where installed: its daily refactor notice
        warnings.simplefilter("ignore", FutureWarning)
        import corner  # here, not at the top: it imports pyplot (+0.25 s), paid only when drawing

    d = result.samples.shape[1]
    fig = Figure(figsize=(1.9 * d, 1.9 * d))
    fig.subplots(d, d)
    corner.corner(
        result.samples,
        fig=fig,
        labels=[_LABELS.get(n, n) for n in result.names],
        quantiles=(0.05, 0.5, 0.95),
        show_titles=True,
        title_fmt=".3g",
        title_kwargs={"fontsize": 9},
        max_n_ticks=4,
        truths=truths,
        truth_color="tab:red",
        plot_datapoints=False,
        smooth=1.0,
        label_kwargs={"fontsize": 10},
    )
    fig.suptitle(
        f"Polach posterior ({result.likelihood} likelihood, {result.diagnostics.n_samples} samples)",
        fontsize=11,
    )
    return fig


def predictive_plot(
    result: PosteriorResult, data: PolachDataset, n_draws: int = 1000, seed: int = 0, truth=None
) -> Figure:
    """Data, posterior-median curve, 90 % credible band of the curve and 90 % posterior-predictive
    band (curve plus the likelihood's noise), all at the dataset's median vehicle speed. For the
    AR(1) likelihoods (``"ar1"``, ``"observer"``) the noise is the stationary marginal,
    ``sigma / sqrt(1 − rho²)``; for ``"observer"`` the band is of the true curve, not of the
    observer's lagged view of it (the samples off the band in transients are that lag)."""
    rng = np.random.default_rng(seed)
    idx = rng.choice(result.samples.shape[0], size=min(n_draws, result.samples.shape[0]), replace=False)
    draws = result.samples[idx]
    # a braking run (negative creep and μ) as magnitudes: the curve is odd in the creep
    sign = -1.0 if float(np.median(np.asarray(data.creep))) < 0 else 1.0
    creep_data, mu_data = sign * np.asarray(data.creep), sign * np.asarray(data.adhesion)
    s_min = max(float(np.min(creep_data[creep_data > 0])), 1e-5)
    creep = np.geomspace(s_min, float(np.max(creep_data)), 300)
    k_eps = jnp.asarray(data.k_eps, float)
    curves = np.asarray(
        posterior_curves(jnp.asarray(draws[:, :5]), jnp.asarray(creep), result.vehicle_speed, k_eps)
    )
    names = list(result.names)
    if "sigma" in names or "b" in names:
        scale = draws[:, names.index("sigma" if "sigma" in names else "b")][:, None]
        if "rho" in names:
            scale = scale / np.sqrt(1.0 - draws[:, names.index("rho")][:, None] ** 2)
        draw = {"laplace": rng.laplace, "student": lambda size: rng.standard_t(STUDENT_NU, size)}
        noise = draw.get(result.likelihood, rng.standard_normal)(size=curves.shape) * scale
    else:
        noise = 0.0
    band = np.quantile(curves, (0.05, 0.5, 0.95), axis=0)
    predictive = np.quantile(curves + noise, (0.05, 0.95), axis=0)

    fig = Figure(figsize=(7.5, 4.8), layout="constrained")
    ax = fig.add_subplot()
    points = ax.scatter(
        creep_data,
        mu_data,
        s=7,
        c=np.asarray(data.vehicle_speed),
        cmap="copper",
        alpha=0.7,
        label=f"data (n = {creep_data.shape[0]})",
        zorder=1,
    )
    fig.colorbar(points, ax=ax, label="vehicle speed of the sample [m/s]")
    ax.fill_between(creep, *predictive, color="tab:blue", alpha=0.18, lw=0, label="90 % predictive")
    ax.fill_between(creep, band[0], band[2], color="tab:blue", alpha=0.45, lw=0, label="90 % credible curve")
    ax.plot(creep, band[1], color="tab:blue", lw=1.8, label="posterior median")
    if truth is not None:
        true_curve = np.asarray(
            posterior_curves(
                jnp.asarray(truth, float)[None, :], jnp.asarray(creep), result.vehicle_speed, k_eps
            )
        )[0]
        ax.plot(creep, true_curve, color="tab:red", lw=1.2, ls="--", label="truth")
    mu_max = result.derived["mu_max"]
    ax.axhline(
        mu_max["median"],
        color="k",
        lw=0.8,
        ls=":",
        label=rf"$\mu_{{max}}$ = {mu_max['median']:.3f} [{mu_max['q05']:.3f}, {mu_max['q95']:.3f}]",
    )
    ax.set_xscale("log")
    ax.set_xlabel("creepage s [-]" if sign > 0 else "creepage |s| [-] (braking)")
    ax.set_ylabel(r"adhesion coefficient $\mu$ [-]" if sign > 0 else r"adhesion coefficient $|\mu|$ [-]")
    ax.set_title(f"Posterior predictive at v = {result.vehicle_speed:.2f} m/s (median speed)")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3, which="both", lw=0.5)
    return fig
