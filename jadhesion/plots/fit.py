"""A fit at a glance: observed adhesion and the fitted Polach curve against slip velocity, and the
residuals in time order (their runs show the observer's colouring of the noise)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..models.polach import polach_adhesion


def fit_figure(data, theta, title=""):
    """Figure with (top) μ̂ and μ_adh(θ) against slip velocity w [m/s] and (bottom) residuals
    μ̂ − μ_adh against sample index. ``data`` a :class:`PolachDataset`, ``theta`` (5,)."""
    slip, mu = np.asarray(data.slip), np.asarray(data.adhesion)
    model = np.asarray(polach_adhesion(theta, data.creep, data.slip, data.k_eps))
    order = np.argsort(slip)
    fig = Figure(figsize=(8, 7), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    top.plot(slip, mu, ".", ms=2, alpha=0.4, color="0.4", label=r"observed $\hat\mu$")
    # μ_adh depends on creep s = w/v as well as w: at varying speed the fit is a band, not a line
    top.plot(slip[order], model[order], ".", ms=1.5, color="C3", label=r"fitted $\mu_{adh}$ at each sample")
    top.set_xscale("symlog", linthresh=1e-2)  # linear below 1 cm/s, where the curve rises
    top.set(
        xlabel="slip velocity w [m/s] (linear below 0.01, log above)",
        ylabel="adhesion coefficient",
        title=title,
    )
    top.legend(loc="lower right", markerscale=6)
    resid = mu - model
    bottom.plot(np.arange(resid.size), resid, "-", lw=0.6, color="C0")
    bottom.axhline(0.0, color="k", lw=0.8)
    bottom.set(
        xlabel="sample (time order)",
        ylabel=r"residual $\hat\mu - \mu_{adh}$",
        title=f"residuals: rms {np.sqrt(np.mean(resid**2)):.3g}",
    )
    return fig
