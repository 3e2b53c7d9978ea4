"""The work of ``jadhesion diagnose`` (arguments: :mod:`.diagnose`): load the recording with the
shared recording options (:func:`.loading.load_from_args`: ``--column``, ``--axle``,
``--missing``, ``--start``/``--end``), select the samples of ``--phase``
(:func:`jadhesion.data.segments.select`: standstill, coasting, direction changes and short
stretches excluded), diagnose, print or emit JSON, write the report.

One exclusion of the fitting commands is undone here: samples whose creep has the opposite sign
of the drive ("torque and creep disagree") are kept, whatever the phase, since that disagreement
is what a wheel-radius error (creep wrong) or a torque offset (torque wrong) produces, and the
diagnosis models it (excluding them hid 1551 of 2000 samples of a simulated recording with a
concealed torque offset and stopped the blind benchmark)."""

from __future__ import annotations

import time
from argparse import Namespace

from ..data.segments import select
from ..data.selected import zero_creep_message
from ..diagnose import diagnose
from ..diagnose.null import N_REPLICAS
from .common import UserError, emit_json, require_in_range, require_output_dir, require_seed, table
from .diagnose import MAX_REPLICAS
from .loading import load_from_args, say_notes


def diagnose_file(
    path,
    columns=(),
    axle=None,
    phase="traction",
    start=None,
    end=None,
    replicas=N_REPLICAS,
    seed=0,
    missing="error",
    repeated_time="error",
) -> tuple:
    """Load a recording (file + sidecar; ``missing`` and ``repeated_time`` as ``--missing`` and
    ``--repeated-time``) and diagnose the samples of
    ``phase`` within ``[start, end]``: ``(result, recording)``; the code path of the CLI, used by
    the benchmarks."""
    args = Namespace(
        column=list(columns), axle=axle, start=start, end=end, missing=missing, repeated_time=repeated_time
    )
    recording = load_from_args(args, path)
    say_notes(recording)
    if not recording.has_raw_signals:
        raise UserError(
            f"{path}: diagnosis needs the raw columns time, vehicle_speed, wheel_speed, traction_torque"
        )
    selection = select(recording, phase)
    mask = selection.mask | (selection.labels == "torque and creep disagree")
    if mask.sum() < 50:
        raise UserError(
            f"{path}: --phase {phase} leaves {int(mask.sum())} samples ({selection.summary()}); "
            "diagnosis needs at least 50"
        )
    if (message := zero_creep_message(recording, mask)) is not None:
        raise UserError(message)
    result = diagnose(recording.columns, recording.vehicle, str(path), replicas, seed, mask)
    result["file"] = str(path)
    result["notes"] = list(recording.notes)
    result["selection"] = {
        **selection.document(),
        "used": int(mask.sum()),
        "kept_disagreeing": int((mask & ~selection.mask).sum()),
    }
    return result, recording


def run(args) -> int:
    require_seed("diagnose", args.seed)
    require_in_range("diagnose", 0, MAX_REPLICAS, replicas=args.replicas)
    require_output_dir("diagnose", "report", args.report)
    start = time.perf_counter()
    result, _ = diagnose_file(
        args.file,
        args.column,
        args.axle,
        args.phase,
        args.start,
        args.end,
        args.replicas,
        args.seed,
        args.missing,
        args.repeated_time,
    )
    result["seconds"] = time.perf_counter() - start
    series = result.pop("_series")
    if args.report:
        from ..diagnose.report import write_report

        result["report"] = str(write_report(result, series, args.report))
    if args.json:
        emit_json(result)
        return 0
    print(
        f"verdict: {result['verdict']}"
        + (f"  (effects: {' + '.join(result['effects'])})" if len(result["effects"]) > 1 else "")
    )
    rows = [
        {
            "candidate": c["name"],
            "heldout_mae": c["heldout_mae"],
            "gain": c["gain"],
            "p_value": c["p_value"],
            "delta_bic": c["delta_bic"],
            "detectable_from": result["sensitivity"][c["name"]]["min_detectable"],
        }
        for c in result["candidates"]
    ]
    rows.insert(0, {"candidate": "(base)", "heldout_mae": result["base"]["heldout_mae"]})
    print(table(rows, ["candidate", "heldout_mae", "gain", "p_value", "delta_bic", "detectable_from"]))
    print(result["explanation"])
    for w in result["warnings"]:
        print(f"warning [{w['code']}]: {w['message']}")
    if args.report:
        print(f"report: {result['report']}")
    return 0
