"""``jadhesion diagnose FILE.csv [--json] [--report DIR]``: the missing physics behind a misfit.

JSON keys (DESIGN §3): ``verdict`` — the primary effect (a catalogue name) or ``"none"``, always a
string; ``effects`` — the accepted effects in order (0, 1 or 2; with two, ``verdict`` is the first);
``candidates`` (name, params, mae, heldout_mae, delta_bic, gain, status, p_value, evidence),
``indistinguishable``, ``base`` and ``extended`` (params, mae, heldout_mae, status), ``generic``,
``null`` (replicas, level, the recording's noise model), ``explanation``, ``seconds``.
"""

from __future__ import annotations

import time

from .common import UserError, emit_json, table
from .recording_options import add_recording_options


def register(sub) -> None:
    p = sub.add_parser("diagnose", help="name the missing physics behind a Polach misfit")
    p.add_argument("file", help="recording CSV (time, vehicle_speed, wheel_speed, traction_torque)")
    p.add_argument(
        "--report", metavar="DIR", default=None, help="write a Markdown report with figures into DIR"
    )
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    add_recording_options(p)
    p.set_defaults(func=run)


def diagnose_file(path, columns=(), axle=None) -> tuple:
    """Load a recording (CSV + sidecar) and diagnose it: ``(result, recording)``; the code path of
    the CLI, used by the blind benchmark too."""
    from ..data.recording import load_recording
    from ..diagnose import diagnose

    recording = load_recording(path, columns=columns, axle=axle)
    if not recording.has_raw_signals:
        raise UserError(
            f"{path}: diagnosis needs the raw columns time, vehicle_speed, wheel_speed, traction_torque"
        )
    return diagnose(recording.columns, recording.vehicle, str(path)), recording


def run(args) -> int:
    start = time.perf_counter()
    result, _ = diagnose_file(args.file, args.column, args.axle)
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
            "delta_bic": c["delta_bic"],
            "detectable_from": result["sensitivity"][c["name"]]["min_detectable"],
        }
        for c in result["candidates"]
    ]
    rows.insert(0, {"candidate": "(base)", "heldout_mae": result["base"]["heldout_mae"]})
    print(table(rows, ["candidate", "heldout_mae", "gain", "delta_bic", "detectable_from"]))
    print(result["explanation"])
    if args.report:
        print(f"report: {result['report']}")
    return 0
