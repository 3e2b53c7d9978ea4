"""``jadhesion inspect``'s work: load, select, summarise, draw (arguments: :mod:`.inspect`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..data.inspection import inspect_document
from ..data.segments import select
from ..data.selected import per_stretch_dataset
from ..plots.recording import recording_overview
from .common import emit_json, require_output_dir, say_written
from .loading import load_from_args


def _time(t: float, step: float | None) -> str:
    """``t`` [s] to six significant digits, or as many as tell samples ``step`` [s] apart (epoch
    times: 1700000000.02, not 1.7e+09)."""
    digits = 6
    if step and t:
        digits = min(17, max(6, math.floor(math.log10(abs(t))) - math.floor(math.log10(step)) + 1))
    return f"{t:.{digits}g}"


#: Excluded runs of one reason less than this apart [s] share one line of the text (a noisy
#: walking-pace start excludes dozens of one- and two-sample runs; the JSON lists each).
GROUP_WITHIN_S = 1.0


def _grouped(runs) -> list:
    """``(reason, start, end, samples, runs)`` per group of same-reason runs (time order) each less
    than :data:`GROUP_WITHIN_S` after the previous one, ordered by start."""
    groups, open_by_reason = [], {}
    for run in runs:
        group = open_by_reason.get(run["reason"])
        if group is not None and run["start"] - group[2] < GROUP_WITHIN_S:
            group[2], group[3], group[4] = run["end"], group[3] + run["samples"], group[4] + 1
        else:
            group = [run["reason"], run["start"], run["end"], run["samples"], 1]
            open_by_reason[run["reason"]] = group
            groups.append(group)
    return groups


def _excluded_line(group, step) -> str:
    reason, start, end, samples, runs = group
    counted = f"{samples} sample{'s' if samples != 1 else ''}"
    return f"  excluded {reason}: {_time(start, step)}–{_time(end, step)} s, " + (
        counted if runs == 1 else f"{counted} in {runs} stretches"
    )


def _text(doc) -> str:
    s, r, sel = doc["sampling"], doc["ranges"], doc["selection"]
    step = s["step_s"]["median"] if s["step_s"] else None
    lines = [f"{doc['file']}: {doc['samples']} samples, columns {', '.join(doc['columns'])}"]
    if s["rate_hz"] is not None:
        lines.append(
            f"duration {s['duration_s']:.6g} s, rate {s['rate_hz']:.4g} Hz, jitter "
            f"{100 * s['jitter']:.2g} % of the step, steps {s['step_s']['min']:.3g}–"
            f"{s['step_s']['max']:.3g} s, {len(s['gaps'])} gap(s)"
            + "".join(f"\n  gap {_time(a, step)} s → {_time(b, step)} s" for a, b in s["gaps"])
        )
    lines.append(
        f"selected: {sel['used']} of {sel['samples']} samples ({sel['phase']})"
        + (f"; {len(sel['stretches'])} stretches between gaps" if len(sel["stretches"]) > 1 else "")
    )
    lines += [_excluded_line(g, step) for g in _grouped(sel["excluded"])]
    if not sel["excluded_listed_all"]:
        lines.append(
            "  (more excluded stretches; counts: "
            + ", ".join(f"{k} {v}" for k, v in sel["counts"].items())
            + ")"
        )
    for name, unit in (("vehicle_speed", "m/s"), ("creep", ""), ("slip_velocity", "m/s"), ("adhesion", "")):
        if r[name] is None:  # no sample selected: the selection line above says why
            lines.append(f"{name:>14}: no selected samples")
            continue
        lo, hi = r[name]
        lines.append(f"{name:>14}: {lo:.4g} … {hi:.4g} {unit}".rstrip())
    lines += [f"identifiability [{n['code']}]: {n['message']}" for n in doc["identifiability"]]
    if not doc["identifiability"]:
        lines.append("identifiability: slip, creep and the peak are covered")
    lines += [f"note: {n}" for n in doc["notes"]]
    return "\n".join(lines)


def run(args) -> int:
    """Inspect one recording and print (or ``--json``) what it holds."""
    require_output_dir("inspect", "plot", args.plot)
    recording = load_from_args(args, args.file)
    selection = select(recording, args.phase)
    full = per_stretch_dataset(recording, selection)
    mask = selection.mask
    chosen = full._replace(
        **{k: np.asarray(getattr(full, k))[mask] for k in ("creep", "slip", "adhesion", "vehicle_speed")}
    )
    doc = inspect_document(recording, selection, chosen)
    if args.plot is not None:
        out = Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        figure = out / "inspect.png"
        recording_overview(recording, mu_hat=np.asarray(full.adhesion), selection=selection).savefig(
            figure, dpi=100
        )
        doc["plots"] = [str(figure)]
    if args.json:
        emit_json(doc)
    else:
        print(_text(doc))
        say_written(doc.get("plots", []))
    return 0
