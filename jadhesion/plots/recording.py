"""Overview figure of one recording: speeds, torque, creep and adhesion against time, and the
adhesion–creep cloud (optionally with the true Polach curve)."""

from __future__ import annotations

from typing import Mapping, Optional

import numpy as np
from matplotlib.figure import Figure
from matplotlib.gridspec import GridSpec

from ..data.dataset import to_dataset
from ..data.vehicle import LOCO_22E
from ..models import kinematics
from ..models.polach import polach_adhesion

_KMH = 3.6


def _creep(cols):
    if "creepage" in cols:
        return np.asarray(cols["creepage"])
    v = np.asarray(cols["vehicle_speed"])
    if "slip_velocity" in cols:
        w = np.asarray(cols["slip_velocity"])
    elif "wheel_speed" in cols:
        w = np.asarray(cols["wheel_speed"]) - v
    else:
        return None
    return np.asarray(kinematics.creepage(w, v))


#: Shading of the excluded stretches (``selection``), by reason.
REASON_COLORS = {
    "standstill": "0.55",
    "coasting": "C9",
    "direction change": "C6",
    "torque and creep disagree": "C8",
    "short stretch": "C7",
    "braking": "C1",
    "traction": "C2",
}


def _shade(ax, selection, labels: bool = True):
    seen = set()
    for run in selection.excluded():
        reason = run["reason"]
        ax.axvspan(
            run["start"],
            run["end"],
            color=REASON_COLORS.get(reason, "0.8"),
            alpha=0.18,
            lw=0,
            label=None if reason in seen or not labels else f"excluded: {reason}",
        )
        seen.add(reason)
    for a, b in selection.gaps:
        ax.axvspan(
            a,
            b,
            facecolor="none",
            edgecolor="k",
            hatch="//",
            lw=0,
            label=None if "gap" in seen or not labels else "gap (not bridged)",
        )
        seen.add("gap")


def recording_overview(
    recording_or_columns, mu_hat=None, truth_params=None, title: Optional[str] = None, selection=None
) -> Figure:
    """An overview of a recording.

    Left, against time (or sample index when there is no ``time`` column): vehicle and wheel speed
    [km/h], traction torque [kN·m], creepage [-] and the adhesion coefficient mu_hat [-]. Right:
    mu_hat against creepage (log axis for an all-positive creep, else symmetric-log), with the true
    Polach curve ``mu_adh(s, w = s·v̄)`` at the mean |vehicle speed| when ``truth_params``
    (``[kA, kS, mu0, A, B]``) is given. Panels whose columns are absent are left out.

    Args:
        recording_or_columns: a :class:`~jadhesion.data.recording.Recording` or a column mapping
            (then the 22E vehicle is assumed for k_eps).
        mu_hat: observed adhesion per sample; default the recording's observer output when it has
            the raw signals (the one rule of :mod:`jadhesion.data.dataset`), else the
            ``adhesion`` column (also for a column mapping), else none.
        truth_params: true Polach parameters to overlay.
        title: figure title (default: the recording's file name).
        selection: a :class:`~jadhesion.data.segments.Selection`: its excluded stretches and gaps
            are shaded against time, and its excluded samples drawn grey in the cloud.
    """
    if isinstance(recording_or_columns, Mapping):
        cols, vehicle, name = recording_or_columns, LOCO_22E, None
    else:
        rec = recording_or_columns
        cols, vehicle, name = rec.columns, rec.vehicle, rec.path.name
    cols = {k: np.asarray(v, dtype=np.float64) for k, v in cols.items()}
    n = len(next(iter(cols.values())))
    raw = all(c in cols for c in ("time", "vehicle_speed", "wheel_speed", "traction_torque"))
    if mu_hat is None and "adhesion" in cols and (not raw or isinstance(recording_or_columns, Mapping)):
        mu_hat = cols["adhesion"]
    elif mu_hat is None and not isinstance(recording_or_columns, Mapping):
        try:
            mu_hat = np.asarray(to_dataset(recording_or_columns).adhesion)
        except ImportError:  # the observer is not available
            mu_hat = None
    mu_hat = None if mu_hat is None else np.asarray(mu_hat, dtype=np.float64)
    creep = _creep(cols)
    if "time" in cols:
        t, t_label = cols["time"], "time [s]"
    else:
        t, t_label = np.arange(n, dtype=float), "sample [-]"

    # Lines break at the gaps between stretches (nothing is drawn across a gap).
    cuts = [] if selection is None else [a for a, _ in selection.stretches[1:]]

    def brk(y):
        return np.insert(np.asarray(y, dtype=np.float64), cuts, np.nan)

    tb = brk(t)
    panels = []
    if "vehicle_speed" in cols or "wheel_speed" in cols:
        panels.append("speed")
    if "traction_torque" in cols:
        panels.append("torque")
    if creep is not None:
        panels.append("creep")
    if mu_hat is not None:
        panels.append("mu")
    right = mu_hat is not None and creep is not None

    fig = Figure(figsize=(13.0, 2.0 + 1.9 * len(panels)), layout="constrained")
    grid = GridSpec(len(panels), 2 if right else 1, figure=fig, width_ratios=[1.35, 1.0] if right else None)
    style = dict(lw=0.9)
    share = None
    for row, panel in enumerate(panels):
        ax = fig.add_subplot(grid[row, 0], sharex=share)
        share = ax
        if panel == "speed":
            if "vehicle_speed" in cols:
                ax.plot(tb, brk(cols["vehicle_speed"] * _KMH), color="C0", label="vehicle", **style)
            if "wheel_speed" in cols:
                ax.plot(
                    tb, brk(cols["wheel_speed"] * _KMH), color="C1", label="wheel (circumferential)", **style
                )
            ax.set_ylabel("speed [km/h]")
            if selection is not None and "time" in cols:
                _shade(ax, selection)
            ax.legend(loc="upper left", fontsize="x-small", frameon=False, ncol=3)
        elif panel == "torque":
            ax.plot(tb, brk(cols["traction_torque"] / 1e3), color="C2", **style)
            ax.set_ylabel("torque [kN·m]")
        elif panel == "creep":
            ax.plot(tb, brk(creep), color="C3", **style)
            if np.all(creep > 0) and np.max(creep) > 100.0 * np.min(creep):
                ax.set_yscale("log")  # a creep sweep spans decades
            ax.set_ylabel("creepage s [-]")
        else:
            ax.plot(tb, brk(mu_hat), color="C4", **style)
            ax.set_ylabel(r"adhesion $\hat\mu$ [-]")
        if selection is not None and "time" in cols and panel != "speed":
            _shade(ax, selection, labels=False)
        ax.grid(alpha=0.3)
        if row < len(panels) - 1:
            ax.tick_params(labelbottom=False)
        else:
            ax.set_xlabel(t_label)

    if right:
        ax = fig.add_subplot(grid[:, 1])
        positive = bool(np.all(creep > 0))
        used = np.ones(n, bool) if selection is None else selection.mask
        ax.scatter(
            creep[used],
            mu_hat[used],
            s=4,
            alpha=0.35,
            color="C4",
            lw=0,
            rasterized=n > 5000,
            label=r"observed $\hat\mu$" + ("" if selection is None else " (selected)"),
            zorder=3,
        )
        if not used.all():
            ax.scatter(
                creep[~used],
                mu_hat[~used],
                s=3,
                alpha=0.2,
                color="0.6",
                lw=0,
                rasterized=n > 5000,
                label="excluded",
                zorder=2,
            )
        if positive:
            ax.set_xscale("log")
        else:
            ax.set_xscale("symlog", linthresh=1e-3, linscale=0.5)
        if truth_params is not None:
            _overlay_truth(ax, truth_params, cols, creep, vehicle, positive)
        ax.set_xlabel("creepage s [-]" + ("" if positive else " (symmetric log)"))
        ax.set_ylabel(r"adhesion coefficient $\hat\mu$ [-]")
        ax.grid(alpha=0.3, which="major")
        ax.grid(alpha=0.1, which="minor")
        ax.legend(loc="lower right", fontsize="small", markerscale=3)
        ax.set_title("adhesion–creep", fontsize="medium")
    fig.suptitle(title if title is not None else (name or "recording"))
    return fig


def _overlay_truth(ax, truth_params, cols, creep, vehicle, positive):
    theta = np.asarray(truth_params, dtype=np.float64)
    v_mean = float(np.mean(np.abs(cols["vehicle_speed"]))) if "vehicle_speed" in cols else 1.0
    hi = float(np.max(np.abs(creep)))
    nz = np.abs(creep)[np.abs(creep) > 0]
    lo = float(np.min(nz)) if positive and nz.size else 1e-4
    lo = min(lo, hi / 10.0) if hi > 0 else 1e-4
    s = np.geomspace(max(lo, 1e-6), max(hi, 1e-5), 400)
    if not positive:
        s = np.concatenate([-s[::-1], [0.0], s])
    mu = np.asarray(polach_adhesion(theta, s, s * v_mean, vehicle.k_eps()))
    ax.plot(s, mu, color="k", lw=1.3, zorder=2, label=f"Polach truth (w = s·v̄, v̄ = {v_mean * _KMH:.2g} km/h)")
