"""A fit at a glance: observed adhesion and the fitted Polach curve against slip velocity, and the
residuals in time order (their runs show the observer's colouring of the noise)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..models.polach import polach_adhesion


def fit_figure(data, theta, title="", peak=None, speed=None):
    """Figure with (top) μ̂ and μ_adh(θ) against slip velocity w [m/s] and (bottom) residuals
    μ̂ − μ_adh against sample index. ``data`` a :class:`PolachDataset`, ``theta`` (5,); ``peak``
    (optional): the fit's ``derived`` block (:mod:`jadhesion.identify.peak`) at ``speed`` [m/s],
    drawn at slip ``creep_opt · speed`` with its 95 % intervals."""
    slip, mu = np.asarray(data.slip), np.asarray(data.adhesion)
    model = np.asarray(polach_adhesion(theta, data.creep, data.slip, data.k_eps))
    order = np.argsort(slip)
    fig = Figure(figsize=(8, 7), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    top.plot(slip, mu, ".", ms=2, alpha=0.4, color="0.4", label=r"observed $\hat\mu$")
    # μ_adh depends on creep s = w/v as well as w: at varying speed the fit is a band, not a line
    top.plot(slip[order], model[order], ".", ms=1.5, color="C3", label=r"fitted $\mu_{adh}$ at each sample")
    if peak is not None:
        _peak_marker(top, peak, speed)
    top.set_xscale("symlog", linthresh=1e-2)  # linear below 1 cm/s, where the curve rises
    top.set(xlabel="slip velocity w [m/s] (linear below 0.01, log above)", ylabel="adhesion coefficient")
    fig.suptitle(title)
    # above the axes, never over the data: a wide sweep fills the lower right too
    legend = top.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=3, frameon=False, fontsize="small")
    for handle in legend.legend_handles:  # the sample dots large enough to see; the peak as drawn
        if getattr(handle, "get_marker", lambda: None)() == ".":
            handle.set_markersize(9)
    resid = mu - model
    bottom.plot(np.arange(resid.size), resid, "-", lw=0.6, color="C0")
    bottom.axhline(0.0, color="k", lw=0.8)
    bottom.set(
        xlabel="sample (time order)",
        ylabel=r"residual $\hat\mu - \mu_{adh}$",
        title=f"residuals: rms {np.sqrt(np.mean(resid**2)):.3g}",
    )
    return fig


def _peak_marker(ax, peak, speed):
    """The peak (μ_max at slip creep_opt · speed) with its 95 % intervals as error bars (none where
    the fit gives no interval)."""
    mu, creep = peak["mu_max"], peak["creep_opt"]
    w = creep["value"] * speed

    def bar(entry, value, scale=1.0):
        ci = entry["ci95"]
        return None if ci is None else [[value - ci[0] * scale], [ci[1] * scale - value]]

    ax.errorbar(
        [w],
        [mu["value"]],
        xerr=bar(creep, w, speed),
        yerr=bar(mu, mu["value"]),
        fmt="D",
        ms=6,
        color="k",
        capsize=4,
        zorder=5,
        label=f"peak at {speed:.3g} m/s: $\\mu_{{max}}$ {mu['value']:.3f}, creep {creep['value']:.3g} (95 %)",
    )
