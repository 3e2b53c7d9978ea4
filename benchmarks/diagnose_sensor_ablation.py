"""Which sensor error makes ``jadhesion diagnose`` flag a clean recording: the same independent-
generator recording (same seed, profile, vehicle and noise draws) diagnosed with one component of
its sensor model switched off at a time.

The generator draws every noise component whether or not it is used, so switching one off leaves
the others' draws unchanged: the variants differ in that component alone. Each variant goes
through a CSV and the CLI's code path (:func:`jadhesion.cli.diagnose_run.diagnose_file`). Recorded
per variant: the verdict, the null's critical SSE reduction and, for the offset-like candidates,
their SSE reduction and p-value; the file records the commit, the settings and the sensor levels.

    python -m benchmarks.diagnose_sensor_ablation [--seed 5002] [--duration 60] [--out FILE]
"""

from __future__ import annotations

import argparse
import copy
import json
import tempfile
from pathlib import Path

from benchmarks.provenance import commit
from jadhesion.cli.diagnose_run import diagnose_file
from jadhesion.config import enable_compilation_cache, enable_x64
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
SPEEDS = ("vehicle_speed", "wheel_speed")
#: Variant name → the sensor settings it changes (applied to a copy of the recording's own).
VARIANTS = {
    "as generated": {},
    "speed AR off": {ch: {"ar": 0.0} for ch in SPEEDS},
    "vehicle speed AR off": {"vehicle_speed": {"ar": 0.0}},
    "wheel speed AR off": {"wheel_speed": {"ar": 0.0}},
    "speed noise off": {ch: {"white": 0.0, "ar": 0.0, "quantum": 0.0} for ch in SPEEDS},
    "torque noise off": {"traction_torque": {"white": 0.0, "ar": 0.0, "quantum": 0.0}},
}
WATCHED = ("torque_offset", "wheel_radius_error", "load_transfer")


def run_variant(seed: int, duration: float, sensor: dict, directory: Path, name: str) -> dict:
    rec = generate(seed, effect="none", duration_s=duration, sensor=sensor)
    path = write(rec, directory / f"{name.replace(' ', '_')}.csv", truth=False)
    result, _ = diagnose_file(path)
    return {
        "verdict": result["verdict"],
        "effects": result["effects"],
        "critical_sse_reduction": result["null"]["critical_sse_reduction"],
        "candidates": {
            c["name"]: {"sse_reduction": c["sse_reduction"], "p_value": c["p_value"], "status": c["status"]}
            for c in result["candidates"]
            if c["name"] in WATCHED
        },
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.diagnose_sensor_ablation", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--seed", type=int, default=5002, help="the generator's seed (default 5002)")
    ap.add_argument("--duration", type=float, default=60.0, help="recording length [s] (default 60)")
    ap.add_argument("--out", default=str(RESULTS / "diagnose_sensor_ablation.json"))
    args = ap.parse_args(argv)
    enable_x64()
    enable_compilation_cache()
    sha = commit()
    sensor = generate(args.seed, effect="none", duration_s=args.duration).truth["sensor"]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, change in VARIANTS.items():
            settings = copy.deepcopy(sensor)
            for channel, values in change.items():
                settings[channel].update(values)
            rows[name] = run_variant(args.seed, args.duration, settings, Path(tmp), name)
            watched = ", ".join(
                f"{k} {v['sse_reduction']:.3f} (p {v['p_value']})"
                for k, v in rows[name]["candidates"].items()
                if v["sse_reduction"] is not None
            )
            print(
                f"{name:22s} verdict {rows[name]['verdict']:18s} critical "
                f"{rows[name]['critical_sse_reduction']:.3f}; {watched}",
                flush=True,
            )
    doc = {"commit": sha, "settings": vars(args), "sensor": sensor, "variants": rows}
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
