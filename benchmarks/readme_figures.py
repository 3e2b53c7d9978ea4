"""The README's figures, made by the command line on recordings from both generators.

``inspect.png``: a recording of the independent generator (validation.foreign_generator: a start
with coasting gaps, its own vehicle and sensors) through ``jadhesion inspect``; ``fit.png``: a
simulated dry 22E test at realistic sensor noise through ``jadhesion fit --method lm``;
``online.png``: the same recording through ``jadhesion online``; ``diagnose.png``: a simulated test
with a concealed rail change through ``jadhesion diagnose --report``. Run
``python -m benchmarks.readme_figures [--out docs/figures]``; the settings and the commit go to
``<out>/figures.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.provenance import commit
from validation.foreign_generator import generate, write

FOREIGN = {"seed": 7, "profile": "start", "rate_hz": 50.0, "duration_s": 60.0, "sensor": "realistic"}
SIMULATED = ["--scenario", "dry", "--seed", "1"]
CHANGE = ["--scenario", "dry", "--seed", "2", "--effect", "rail_change=0.06"]


def _cli(*args) -> None:
    subprocess.run(
        [sys.executable, "-m", "jadhesion", *map(str, args)], check=True, stdout=subprocess.DEVNULL
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.readme_figures", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--out", default="docs/figures")
    out = Path(ap.parse_args(argv).out)
    out.mkdir(parents=True, exist_ok=True)
    sha = commit()  # before the figures overwrite tracked files: those are what the run makes
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        foreign = write(
            generate(FOREIGN["seed"], **{k: v for k, v in FOREIGN.items() if k != "seed"}),
            tmp / "foreign.csv",
        )
        _cli("inspect", foreign, "--plot", tmp / "inspect")
        shutil.copy(tmp / "inspect" / "inspect.png", out / "inspect.png")
        _cli("simulate", *SIMULATED, "--out", tmp / "dry.csv")
        _cli("fit", tmp / "dry.csv", "--method", "lm", "--plot", tmp / "fit")
        shutil.copy(tmp / "fit" / "fit.png", out / "fit.png")
        _cli("online", tmp / "dry.csv", "--plot", tmp / "online")
        shutil.copy(tmp / "online" / "dry_online.png", out / "online.png")
        _cli("simulate", *CHANGE, "--out", tmp / "change.csv")
        _cli("diagnose", tmp / "change.csv", "--report", tmp / "report")
        figures = sorted((tmp / "report").glob("*.png"))
        shutil.copy(figures[0], out / "diagnose.png")
    settings = {
        "foreign": FOREIGN,
        "simulated": SIMULATED,
        "rail_change": CHANGE,
        "diagnose_figure": figures[0].name,
    }
    (out / "figures.json").write_text(json.dumps({"commit": sha, "settings": settings}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
