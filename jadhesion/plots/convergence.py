"""Convergence of the population optimisers, like paper 001's Figure 9 (median and IQR band)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..models.polach import PARAM_NAMES

_STYLE = {"itlbo": ("C3", "improved TLBO"), "tlbo": ("C0", "TLBO"), "pso": ("C2", "PSO")}
_LABELS = {"kA": "$k_A$", "kS": "$k_S$", "mu0": r"$\mu_0$", "A": "$A$", "B": "$B$ [s/m]"}


def convergence_figure(trace, scenario):
    """Error and each Polach parameter against iteration, all methods, median with IQR band.

    ``trace``: ``{"histories": {method: {"error": (seeds, iters), "params": (seeds, iters, 5)}},
    "truth": (5,), "floor": (seeds,)}`` as produced by :func:`jadhesion.experiments.table2.run_scenario`.
    """
    fig = Figure(figsize=(13, 7), layout="constrained")
    axes = fig.subplots(2, 3)
    panels = [("error", None)] + [(name, i) for i, name in enumerate(PARAM_NAMES)]
    for ax, (name, idx) in zip(axes.flat, panels, strict=True):
        for method, hist in trace["histories"].items():
            series = hist["error"] if idx is None else hist["params"][..., idx]
            it = np.arange(1, series.shape[1] + 1)
            q25, q50, q75 = np.percentile(series, [25, 50, 75], axis=0)
            color, label = _STYLE.get(method, ("k", method))
            ax.plot(it, q50, color=color, label=label, lw=1.6)
            ax.fill_between(it, q25, q75, color=color, alpha=0.2, lw=0)
        if idx is None:
            ax.axhline(
                np.median(trace["floor"]), color="k", ls="--", lw=1, label="true parameters (noise floor)"
            )
            ax.set_yscale("log")
            ax.set_ylabel("mean absolute error (eq 15)")
            ax.legend(fontsize=8)
        else:
            ax.axhline(trace["truth"][idx], color="k", ls="--", lw=1, label="true")
            ax.set_ylabel(_LABELS[name])
        ax.set_xscale("log")
        ax.set_xlabel("iteration")
        ax.grid(alpha=0.3, which="both")
    fig.suptitle(f"Polach identification, {scenario} rail: median and interquartile band over seeds")
    return fig
