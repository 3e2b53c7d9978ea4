"""``jadhesion online``'s work: load, observe, track, print or ``--json`` (arguments: :mod:`.online`).

Unknown sidecar keys are said on stderr as soon as the recording is loaded and listed in
``warnings`` (``sidecar_unknown_key``, :func:`jadhesion.data.sidecar.sidecar_warning`)."""

from __future__ import annotations

import math
from pathlib import Path

import jax
import numpy as np

from ..data.selected import creep_sign_warning, stuck_speed_warning, tracking_dataset
from ..identify.kiencke_fit import A_S_LOG10_BOUNDS, MIN_SAMPLES
from ..identify.online import (
    REFERENCE_STEP_S,
    below_data_warning,
    extrapolated_warning,
    few_samples_warning,
    hold_warning,
    optimum_warning,
    singular_warning,
    track_dataset,
)
from ..plots.online import recording_figure
from ..status import status_of
from .common import (
    UserError,
    emit_json,
    require_in_range,
    require_output_dir,
    require_seed,
    say_written,
    table,
)
from .loading import load_from_args, say_notes_and_sidecar_warning

TRACK_FIELDS = ("p1", "p2", "mu_max", "creep_opt", "eta")


def _finite(v):
    v = float(v)
    return v if math.isfinite(v) else None


def run(args) -> int:
    require_seed("online", args.seed)
    require_in_range("online", *(10.0**b for b in A_S_LOG10_BOUNDS), a_s=args.a_s)  # the offline fit's box
    require_output_dir("online", "plot", args.plot)
    recording = load_from_args(args, args.file)
    sidecar = say_notes_and_sidecar_warning(recording)
    rows = recording.n_samples
    if rows < MIN_SAMPLES:  # before the observer and smoother are compiled (2-9 s)
        raise UserError(f"{args.file}: {rows} samples; online identification needs at least {MIN_SAMPLES}")
    data, selection = tracking_dataset(recording, args.phase)
    cols = recording.columns
    clock = np.asarray(cols["time"]) if "time" in cols else None  # None: no time column
    per_second = clock if args.forgetting == "seconds" else None
    out = track_dataset(data, args.algorithm, args.a_s, jax.random.key(args.seed), per_second)
    used = np.asarray(out.used)
    status = status_of(out.status)
    if status.name == "NOT_RUN":
        raise UserError(
            f"{args.file}: only {int(used.sum())} informative samples of --phase {args.phase} "
            f"(|v| >= 0.1 m/s, |adhesion| >= 0.02); online identification needs at least {MIN_SAMPLES}"
        )
    time = np.arange(used.size, dtype=float) if clock is None else clock
    tr = out.trace
    doc = {
        "file": str(args.file),
        "algorithm": args.algorithm,
        "a_s": float(out.a_s),
        "a_s_source": "given" if args.a_s is not None else "estimated",
        "forgetting": {"per": out.forgetting, "reference_step_s": REFERENCE_STEP_S},
        "final": {f: _finite(getattr(tr, f)[-1]) for f in ("p1", "p2", "mu_max", "creep_opt")},
        "status": status.label,
        "converged": status.converged,
        "n_samples": int(used.size),
        "n_used": int(used.sum()),
        "selection": selection.document(),
        "notes": list(recording.notes),
        "track": {"time": time, **{f: np.asarray(getattr(tr, f)) for f in TRACK_FIELDS}, "used": used},
        "warnings": [
            w
            for w in (
                sidecar,
                creep_sign_warning(recording, selection),
                stuck_speed_warning(recording),
                few_samples_warning(out),
                singular_warning(out),
                hold_warning(out, clock),
                optimum_warning(out),
                below_data_warning(out, data.adhesion, clock),
                extrapolated_warning(out, data.creep),
            )
            if w is not None
        ],
    }
    if out.slope_fit is not None:
        fit = out.slope_fit
        doc["a_s_fit"] = {
            "method": "lm",
            "p1": float(fit.params[0]),
            "p2": float(fit.params[1]),
            "mae": float(fit.mae),
            "status": status_of(fit.status).label,
            "converged": status_of(fit.status).converged,
        }
    if args.plot is not None:
        Path(args.plot).mkdir(parents=True, exist_ok=True)
        path = Path(args.plot) / f"{Path(args.file).stem}_online.png"
        fig = recording_figure(
            time,
            data.adhesion,
            data.creep,
            tr,
            used,
            title=f"{Path(args.file).name}: online Kiencke, algorithm "
            f"{args.algorithm}, a_s = {doc['a_s']:.4g}",
            time_label="time [s]" if "time" in cols else "sample",
            hold=next(((w["from_s"], w["to_s"]) for w in doc["warnings"] if w["code"] == "snr_hold"), None),
        )
        fig.savefig(path, dpi=110)
        doc["plots"] = [str(path)]
    if args.json:
        emit_json(doc)
    else:
        rows = [
            {"quantity": k, "final": "none" if v is None else f"{v:.5g}"} for k, v in doc["final"].items()
        ]
        print(table(rows, ["quantity", "final"]))
        print(
            f"algorithm {args.algorithm}, forgetting per {out.forgetting[:-1]}, "
            f"a_s {doc['a_s']:.5g} ({doc['a_s_source']}), "
            f"{doc['n_used']}/{doc['n_samples']} samples used, status {doc['status']}"
        )
        for w in doc["warnings"]:
            print(f"warning [{w['code']}]: {w['message']}")
        say_written(doc.get("plots", []))
    return 0
