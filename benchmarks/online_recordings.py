"""``jadhesion online`` on recordings of both generators: holds, warnings and the tracked peak.

Recordings: our simulator's dry, wet and sand tests (``jadhesion simulate``, seeds 1–3, its defaults:
40 s at 50 Hz, realistic sensors) and the independent generator's (:mod:`validation.foreign_generator`,
no effect, mild sensors) 4 steady runs (its default 60 s) and 4 walking-pace starts (30 s), seeds
0–3. Each goes through ``jadhesion online --json`` with every identifier. Per run: the warnings
(``snr_hold`` with its span, ``no_optimum``), and over the second half of the record the median
relative error of the tracked ``mu_max`` and the median tracked ``creep_opt`` against the
generator's own Polach peak (:func:`jadhesion.models.polach.adhesion_peak` at the median
``|v|``; Kiencke's curve is not Polach's, so this is how near the tracker's peak comes, not a
parameter recovery). Run ``python -m benchmarks.online_recordings [--out FILE]``; the commit, the
settings and the rows go to ``benchmarks/results/online_recordings.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from benchmarks.provenance import commit
from jadhesion.cli import main as cli_main
from jadhesion.cli.online import ALGORITHM_NAMES
from jadhesion.config import enable_x64
from jadhesion.data.recording import load_recording
from jadhesion.models.polach import adhesion_peak
from validation.foreign_generator import generate, write

RESULTS = Path(__file__).resolve().parent / "results"
OURS = [(scenario, seed) for scenario in ("dry", "wet", "sand") for seed in (1, 2, 3)]
FOREIGN = [("steady", seed) for seed in range(4)] + [("start", seed) for seed in range(4)]


def _recordings(tmp: Path):
    """``(name, csv path)`` of every recording, written into ``tmp``."""
    for scenario, seed in OURS:
        path = tmp / f"{scenario}_{seed}.csv"
        subprocess.run(
            [sys.executable, "-m", "jadhesion", "simulate", "--scenario", scenario, "--seed", str(seed),
             "--out", str(path)],
            check=True,
            stdout=subprocess.DEVNULL,
        )  # fmt: skip
        yield f"ours/{scenario}/{seed}", path
    for profile, seed in FOREIGN:
        kw = {"profile": "start", "duration_s": 30.0} if profile == "start" else {}
        rec = generate(seed, effect="none", sensor="mild", **kw)
        yield f"foreign/{profile}/{seed}", write(rec, tmp / f"foreign_{profile}_{seed}.csv")


def truth_peak(path: Path) -> tuple[float, float]:
    """The recording's true Polach peak ``(mu_max, creep_opt)`` at its median ``|v|``."""
    truth = json.loads(path.with_suffix(".truth.json").read_text())
    rec = load_recording(path)
    theta = jnp.array([truth["params"][k] for k in ("kA", "kS", "mu0", "A", "B")])
    k_eps = truth.get("k_eps") or float(rec.vehicle.k_eps())
    speed = float(np.median(np.abs(np.asarray(rec.columns["vehicle_speed"]))))
    return tuple(float(x) for x in adhesion_peak(theta, k_eps, speed))


def _online(path: Path, algorithm: str) -> dict:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli_main(["online", str(path), "--algorithm", algorithm, "--json"])
    if code != 0:
        raise RuntimeError(f"online {path} --algorithm {algorithm}: exit {code}")
    return json.loads(out.getvalue())


def _row(name: str, algorithm: str, doc: dict, peak: tuple[float, float]) -> dict:
    track = doc["track"]
    time = np.asarray(track["time"], float)
    late = time > 0.5 * time[-1]
    mu_max = np.asarray(track["mu_max"], float)
    creep = np.array([np.nan if c is None else c for c in track["creep_opt"]], float)
    hold = next((w for w in doc["warnings"] if w["code"] == "snr_hold"), None)
    return {
        "recording": name,
        "algorithm": algorithm,
        "warnings": [w["code"] for w in doc["warnings"]],
        "hold": None if hold is None else {k: hold[k] for k in ("from_s", "to_s", "samples", "to_end")},
        "true_mu_max": peak[0],
        "true_creep_opt": peak[1],
        "mu_max_rel_error_median": float(np.median(np.abs(mu_max[late] / peak[0] - 1.0))),
        "creep_opt_median": float(np.nanmedian(creep[late])) if np.isfinite(creep[late]).any() else None,
        "final": doc["final"],
    }


def _group(rows: list, prefix: str) -> list:
    return [r for r in rows if r["recording"].startswith(prefix)]


def _summary(rows: list) -> dict:
    out = {}
    for algorithm in ALGORITHM_NAMES:
        mine = [r for r in rows if r["algorithm"] == algorithm]
        out[algorithm] = {
            "runs": len(mine),
            "snr_hold": sum(r["hold"] is not None for r in mine),
            "snr_hold_to_end": sum(r["hold"] is not None and r["hold"]["to_end"] for r in mine),
            "no_optimum": sum("no_optimum" in r["warnings"] for r in mine),
            "mu_max_rel_error_median": {
                group: float(np.median([r["mu_max_rel_error_median"] for r in _group(mine, group)]))
                for group in ("ours/", "foreign/")
            },
        }  # fmt: skip
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.online_recordings", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--out", default=str(RESULTS / "online_recordings.json"))
    args = ap.parse_args(argv)
    enable_x64()
    sha = commit()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, path in _recordings(Path(tmp)):
            peak = truth_peak(path)
            for algorithm in ALGORITHM_NAMES:
                rows.append(_row(name, algorithm, _online(path, algorithm), peak))
                err, codes = rows[-1]["mu_max_rel_error_median"], rows[-1]["warnings"]
                print(f"{name:20s} {algorithm:9s} mu_max error {err:.3f} {codes}")
    summary = _summary(rows)
    doc = {
        "commit": sha,
        "settings": {
            "ours": OURS,
            "foreign": FOREIGN,
            "foreign_sensor": "mild",
            "algorithms": list(ALGORITHM_NAMES),
        },
        "summary": summary,
        "rows": rows,
    }
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
