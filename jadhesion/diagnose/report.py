"""Markdown report with three figures: μ̂ against creep before/after, the base residual against
the signal that reveals the effect, and the candidate ranking."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..models.effects import EFFECTS, on_clock
from .select import GAIN_THRESHOLD

UNITS = {
    "time": "time [s]",
    "creep": "creepage [-]",
    "speed": "vehicle speed [m/s]",
    "accel": "acceleration [m/s²]",
    "torque_rate": "torque rate d(T/mgr)/dt [1/s]",
    "heat": "filtered frictional power [W]",
    "traction_ratio": "tractive effort F_t/(M g) [-]",
    "adhesion": "predicted adhesion [-]",
}


def _binned(x, y, bins=20):
    edges = np.quantile(x, np.linspace(0, 1, bins + 1))
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
    centres = np.array([x[idx == k].mean() for k in range(bins) if np.any(idx == k)])
    means = np.array([y[idx == k].mean() for k in range(bins) if np.any(idx == k)])
    return centres, means


def figures(result: dict, series: dict, out: Path) -> list:
    """Render the figures into ``out``; returns their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    creep, target = series["creep"], series["target"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, key, title in (
        (axes[0], "base", "base Polach fit"),
        (axes[1], "extended", "extended: " + (" + ".join(result["effects"]) or "none")),
    ):
        ax.plot(creep, target, ".", ms=2, color="0.6", label="observed μ̂")
        ax.plot(creep, series[f"{key}_pred"], ".", ms=2, color="C3", label="model")
        ax.set_xscale("symlog", linthresh=0.01)
        ax.set_xlabel("creepage s [-]")
        ax.set_title(f"{title}\nheld-out MAE {result[key]['heldout_mae']:.4f}")
    axes[0].set_ylabel("adhesion μ [-]")
    axes[0].legend(loc="lower right", markerscale=4)
    fig.tight_layout()
    fig.savefig(out / "adhesion_vs_creep.png", dpi=110)
    plt.close(fig)
    names.append("adhesion_vs_creep.png")

    signal = series["revealing_signal"]
    x = series["signals"][signal]
    fig, ax = plt.subplots(figsize=(6.5, 4))
    ax.plot(x, series["base_residual"], ".", ms=2, color="0.65", label="base residual")
    ax.plot(*_binned(x, series["base_residual"]), "o-", color="C0", label="base, binned mean")
    ax.plot(*_binned(x, series["extended_residual"]), "s-", color="C2", label="extended, binned mean")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel(UNITS[signal])
    ax.set_ylabel("μ̂ − model [-]")
    ax.set_title(f"residual against {signal} (η² = {result['residual_signatures'][signal]:.2f})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "residual_signature.png", dpi=110)
    plt.close(fig)
    names.append("residual_signature.png")

    cands = result["candidates"][::-1]
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    colors = ["C3" if c["name"] in result["effects"] else "0.6" for c in cands]
    bars = ax.barh([c["name"] for c in cands], [100 * c["gain"] for c in cands], color=colors)
    untested = [bar for bar, c in zip(bars, cands, strict=True) if c["status"] != "converged"]
    for k, bar in enumerate(untested):  # never ranked: hatched, one legend entry
        bar.set(
            hatch="///",
            edgecolor="k",
            facecolor="white",
            label="_" if k else "fit not converged (not ranked)",
        )
    ax.axvline(100 * GAIN_THRESHOLD, color="k", ls="--", lw=0.8, label="calibrated threshold")
    ax.set_xlabel("held-out error reduction vs base [%]")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(out / "candidate_ranking.png", dpi=110)
    plt.close(fig)
    names.append("candidate_ranking.png")
    return names


def _p_text(p) -> str:
    """A p-value for the table; ``–`` for a candidate not tested (no null, or a fit that did not
    converge)."""
    return "–" if p is None else f"{p:.2f}"


def _stderr(extended: dict, name: str) -> str:
    """A parameter's standard error (``extended.uncertainty``), or "—" where it has none."""
    sd = extended["uncertainty"]["stderr"].get(name)
    return "—" if sd is None else f"{sd:.2g}"


def _value(name: str, value: float, start: float) -> str:
    """A parameter's value for the table; a rail change's time on the recording's clock
    (:func:`jadhesion.models.effects.on_clock`, ``start`` its first fitted sample [s])."""
    return on_clock((value,), start) if name == "t_change_s" else f"{value:.4g}"


def _interval(extended: dict, name: str, start: float = 0.0) -> str:
    """A parameter's 90 % interval: the profile interval for a rail change's time (on the
    recording's clock, as :func:`_value`), else the standard-error one (``extended.uncertainty``);
    "—" where it has none."""
    found = extended["change_time"]
    if name == "t_change_s" and found:
        return f"{on_clock(found['t_change_interval_s'], start)} (profile)"
    ci = extended["uncertainty"]["ci90"].get(name)
    return "—" if ci is None else f"{ci[0]:.4g} – {ci[1]:.4g}"


def write_report(result: dict, series: dict, directory) -> Path:
    """Write ``report.md`` and its figures into ``directory``; returns the Markdown path."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    figs = figures(result, series, out)
    rows = "\n".join(
        f"| {c['name']} | {c['heldout_mae']:.5f} | {100 * c['gain']:+.1f} % | "
        f"{c['delta_bic']:+.1f} | {_p_text(c['p_value'])} | {c['status']} | "
        f"{c['evidence']['signal']} |"
        for c in result["candidates"]
    )
    start = result.get("time_start_s", 0.0)
    params = "\n".join(
        f"| {k} | {_value(k, v, start)} | {_stderr(result['extended'], k)} | "
        f"{_interval(result['extended'], k, start)} |"
        for k, v in result["extended"]["params"].items()
    )
    seen = "\n".join(
        f"| {n} | {s['min_detectable']:.3g} | {100 * s['absorbed']:.0f} % | "
        f"{'yes' if s['visible'] else 'no: ' + s['experiment']} | "
        "{} of {} |".format(*EFFECTS[n].detection.own_limit)
        for n, s in result["sensitivity"].items()
    )
    warnings = "\n".join(f"- **{w['code']}**: {w['message']}" for w in result["warnings"]) or "None."
    text = f"""# Diagnosis: {result["verdict"]}

{result["explanation"]}

| model | MAE | held-out MAE |
|---|---|---|
| base Polach | {result["base"]["mae"]:.5f} | {result["base"]["heldout_mae"]:.5f} |
| extended ({" + ".join(result["effects"]) or "none"}) | {result["extended"]["mae"]:.5f} | \
{result["extended"]["heldout_mae"]:.5f} |

| extended parameter | value | standard error | 90 % interval |
|---|---|---|---|
{params}

Standard errors and intervals are conditional on the extended model (HAC sandwich at the fit); a
rail change's time has a profile interval instead ("—": on a bound of its box, not determined by
the data, or not a fitted parameter).

![adhesion against creep]({figs[0]})

![residual signature]({figs[1]})

## Candidates (round 1, best held-out error first)

| effect | held-out MAE | gain | ΔBIC | p (max-T null) | fit status | revealing signal |
|---|---|---|---|---|---|---|
{rows}

![candidate ranking]({figs[2]})

Decision: an effect is found when a candidate whose fits converged has a gain above the
calibrated {100 * GAIN_THRESHOLD:.1f} %, a max-T p-value against {result["null"]["replicas"]}
clean re-synthesised replicas of this recording ≤ {result["null"]["alpha"]} and ΔBIC < 0
(n_eff = {result["n_eff"]:.0f}); the one named is the lowest ΔBIC among the candidates that pass
the null and BIC, whatever their held-out gain (a held-out block extrapolates the fit).

## Warnings

{warnings}

## What this recording can see

The smallest magnitude of each effect (catalogue units) whose signature, after the fitted model
absorbs what it can, would reach the decision threshold (linearised at the final fit). The last
column: of the blind test cases (both generators) whose size reached their recording's own limit,
how many were named.

| effect | smallest detectable | absorbed by the model | visible at typical size | blind: named above it |
|---|---|---|---|---|
{seen}
"""
    path = out / "report.md"
    path.write_text(text)
    return path
