"""Paper 000's Figures 4–6 with Monte Carlo bands: p1, p2 and μ_m against step k."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..models.kiencke import DEFAULT_SLOPE  # noqa: E402

_STYLE = {"1": ("tab:blue", "Algorithm 1"), "2": ("tab:orange", "Algorithm 2")}


def figure(bands: dict, truth, a_s=DEFAULT_SLOPE):
    """Three stacked panels; ``bands[alg][field]`` is (3, K): 5 %, median, 95 % over runs.

    ``truth`` (K, 2) holds the true ``[p1, p2]`` per step; the true peak adhesion follows from it.
    The y-range is clipped to the truth's range ±60 % so a wild first step does not flatten the rest.
    """
    truth = np.asarray(truth)
    true = {"p1": truth[:, 0], "p2": truth[:, 1],
            "mu_max": a_s / (truth[:, 0] + 2.0 * np.sqrt(truth[:, 1]))}
    labels = {"p1": "$p_1$ (Fig. 4)", "p2": "$p_2$ (Fig. 5)", "mu_max": r"$\mu_m$ (Fig. 6)"}
    k = np.arange(1, truth.shape[0] + 1)
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True, constrained_layout=True)
    for ax, field in zip(axes, ("p1", "p2", "mu_max")):
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
