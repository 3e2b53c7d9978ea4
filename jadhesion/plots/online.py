"""Paper 000's Figures 4–6 with Monte Carlo bands: p1, p2 and μ_m against step k."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..models.kiencke import DEFAULT_SLOPE

_STYLE = {"1": ("tab:blue", "Algorithm 1"), "2": ("tab:orange", "Algorithm 2")}


def figure(bands: dict, truth, a_s=DEFAULT_SLOPE):
    """Three stacked panels; ``bands[alg][field]`` is (3, K): 5 %, median, 95 % over runs.

    ``truth`` (K, 2) holds the true ``[p1, p2]`` per step; the true peak adhesion follows from it.
    The y-range is clipped to the truth's range ±60 % so a wild first step does not flatten the rest.
    """
    truth = np.asarray(truth)
    true = {"p1": truth[:, 0], "p2": truth[:, 1], "mu_max": a_s / (truth[:, 0] + 2.0 * np.sqrt(truth[:, 1]))}
    labels = {"p1": "$p_1$ (Fig. 4)", "p2": "$p_2$ (Fig. 5)", "mu_max": r"$\mu_m$ (Fig. 6)"}
    k = np.arange(1, truth.shape[0] + 1)
    fig = Figure(figsize=(8, 9), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    for ax, field in zip(axes, ("p1", "p2", "mu_max"), strict=True):
        for alg, band in bands.items():
            color, name = _STYLE.get(alg, ("tab:gray", alg))
            lo, med, hi = np.asarray(band[field])
            ax.fill_between(k, lo, hi, color=color, alpha=0.25, lw=0, label=f"{name} 5–95 %")
            ax.plot(k, med, color=color, lw=1.2, label=f"{name} median")
        ax.plot(k, true[field], "k--", lw=1.0, label="truth")
        span = true[field].max() - true[field].min()
        ax.set_ylim(true[field].min() - 0.6 * span, true[field].max() + 0.6 * span)
        ax.set_ylabel(labels[field])
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=3, fontsize=8, loc="upper left")
    axes[-1].set_xlabel("step k")
    axes[0].set_title("Online Kiencke identification: Monte Carlo median and 5–95 % band")
    return fig


def recording_figure(time, mu_hat, creep, trace, used, title="", time_label="time [s]", hold=None):
    """The tracked optimum over a recording: top, observed |μ̂| (grey dots; skipped samples lighter)
    with the tracked peak adhesion μ_m; middle, |creep| (log scale) with the tracked optimum creep λ_m
    (a gap where ``p2 ≤ 0``: no optimum); bottom,
    the forgetting factor η. ``trace`` is an :class:`~jadhesion.identify.online.OnlineInfo`;
    ``hold``: ``(from, to)`` of the SNR step's hold (:func:`~jadhesion.identify.online.hold_warning`),
    shaded on every panel."""
    time, mu_hat, creep, used = map(np.asarray, (time, mu_hat, creep, used))
    mu_hat, creep = np.abs(mu_hat), np.abs(creep)  # braking: magnitudes (both models are odd)
    fig = Figure(figsize=(9, 8), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True, height_ratios=(3, 2, 1))
    for ax, obs, est, name, label in (
        (axes[0], mu_hat, trace.mu_max, "observed $\\hat\\mu$", "tracked peak $\\mu_m$"),
        (
            axes[1],
            creep,
            trace.creep_opt,
            "creep $\\lambda$",
            "tracked optimum creep $\\lambda_m$ (gap: no optimum)",
        ),
    ):
        ax.plot(time[used], obs[used], ".", ms=2, color="0.45", label=name)
        ax.plot(time[~used], obs[~used], ".", ms=2, color="0.85", label="skipped (standstill, coasting)")
        est = np.asarray(est, dtype=float)
        ax.plot(time, np.where(np.isfinite(est), est, np.nan), color="tab:red", lw=1.4, label=label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    top = np.quantile(mu_hat[used], 0.995) if used.any() else 1.0
    axes[0].set_ylim(0.0, 1.3 * top)
    axes[0].set_ylabel("|adhesion| [-]")
    axes[1].set_yscale("log")
    axes[1].set_ylim(max(np.quantile(creep[used], 0.005), 1e-4) / 2 if used.any() else 1e-4, 1.5)
    axes[1].set_ylabel("|creep| [-]")
    axes[2].plot(time, np.asarray(trace.eta), color="tab:blue", lw=0.8)
    if hold is not None:
        for ax in axes:
            label = "SNR step holds $\\eta = \\eta_{max}$" if ax is axes[2] else None
            ax.axvspan(*hold, color="tab:orange", alpha=0.15, lw=0, label=label)
        axes[2].legend(fontsize=8, loc="lower right")
    axes[2].set_ylabel("forgetting $\\eta$")
    axes[2].set_xlabel(time_label)
    axes[2].grid(alpha=0.3)
    axes[0].set_title(title)
    return fig
