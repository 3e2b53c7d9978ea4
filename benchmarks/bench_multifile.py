"""Many recordings, one process (issue #16 item 3): ``jadhesion fit A B … F`` against six
``jadhesion fit X`` processes, and fits per second for 100 recordings.

Recordings are simulated in-process (``jadhesion simulate``: dry/wet/sand in turn, durations
spread over 20–40 s at 50 Hz, i.e. 1 000–2 000 samples: length buckets 1 024 and 2 048; realistic
sensor noise × ``--noise``). One untimed warm-up call fills the compilation cache and the kept
programs (shared by single and many-file calls: both run the bucket programs), then
``--repeats`` interleaved rounds, each timing:

* ``six_calls``: six ``jadhesion fit FILE --json`` processes, one after the other (total wall);
* ``one_call``: one ``jadhesion fit F1 … F6 --json`` process;
* ``hundred``: one ``jadhesion fit DIR --json`` process on 100 recordings (fits/s = 100 / wall,
  start-up included; ``fit_seconds`` is the sum of the per-file ``seconds``, fits only).

Medians are reported. Also, in this process (library, warm): the 100 datasets fitted one at a
time (:func:`jadhesion.identify.batch_fit.fit_datasets`) and vmapped per bucket
(:func:`~jadhesion.identify.batch_fit.fit_datasets_vmapped`). Results go to
``benchmarks/results/bench_multifile.json`` with the git commit and the settings. Run as
``python -m benchmarks.bench_multifile [--repeats 3] [--method lm] [--model polach] [--count 100]``
(``--out`` another file for another model).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .provenance import commit

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bench_multifile.json"
SCENARIOS = ("dry", "wet", "sand")


def _simulate(folder: Path, count: int, noise: float) -> list[Path]:
    from jadhesion.cli import main

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        path = folder / f"rec{i:03d}.csv"
        duration = 20.0 + 19.98 * ((i * 7) % 11) / 10
        with contextlib.redirect_stdout(io.StringIO()):
            assert (
                main(
                    [
                        "simulate",
                        "--scenario",
                        SCENARIOS[i % 3],
                        "--seed",
                        str(i),
                        "--duration",
                        f"{duration:.2f}",
                        "--sensor-noise",
                        str(noise),
                        "--out",
                        str(path),
                    ]
                )
                == 0
            )
        paths.append(path)
    return paths


def _fit(paths, method, model, env) -> tuple[float, dict]:
    argv = [sys.executable, "-m", "jadhesion", "fit", *map(str, paths), "--method", method, "--model", model]
    argv.append("--json")
    start = time.perf_counter()
    proc = subprocess.run(argv, env=env, check=True, capture_output=True, text=True, timeout=900)
    return time.perf_counter() - start, json.loads(proc.stdout)


def _library(paths, method, model) -> dict:
    import jax

    from jadhesion.cli.fit_program import to_dataset
    from jadhesion.config import enable_x64
    from jadhesion.data.recording import load_recording
    from jadhesion.identify.batch_fit import fit_datasets, fit_datasets_vmapped
    from jadhesion.identify.kiencke_fit import fit_kiencke

    enable_x64()
    datasets = [to_dataset(load_recording(p)) for p in paths]
    key = jax.random.key(0)
    out = {}
    calls = {"one_at_a_time": lambda: fit_datasets(datasets, method, key)}
    if model == "kiencke":
        calls = {"one_at_a_time": lambda: fit_datasets(datasets, method, key, fit=fit_kiencke)}
    else:
        calls["vmapped"] = lambda: fit_datasets_vmapped(datasets, method, key)
    for name, call in calls.items():
        call()  # compile
        start = time.perf_counter()
        call()
        seconds = time.perf_counter() - start
        out[name] = {"seconds": seconds, "fits_per_second": len(datasets) / seconds}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (default 3)")
    parser.add_argument("--method", default="lm", help="fit method (default lm)")
    parser.add_argument("--model", default="polach", help="polach (default) or kiencke")
    parser.add_argument("--count", type=int, default=100, help="recordings of the large call")
    parser.add_argument("--noise", type=float, default=1.0, help="sensor-noise scale (default 1)")
    parser.add_argument("--no-library", action="store_true", help="skip the in-process timings")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)

    work = Path(tempfile.mkdtemp(prefix="bench-multifile-"))
    env = dict(os.environ, JADHESION_CACHE=str(work / "cache"))
    os.environ["JADHESION_CACHE"] = env["JADHESION_CACHE"]
    many = _simulate(work / "hundred", args.count, args.noise)
    six = many[:6]
    _fit(many, args.method, args.model, env)  # warm-up: every bucket's program compiled and kept
    for p in six:
        _fit([p], args.method, args.model, env)

    times: dict = {"six_calls": [], "one_call": [], "hundred": [], "hundred_fit_seconds": []}
    for _ in range(args.repeats):
        times["six_calls"].append(sum(_fit([p], args.method, args.model, env)[0] for p in six))
        times["one_call"].append(_fit(six, args.method, args.model, env)[0])
        wall, doc = _fit(many, args.method, args.model, env)
        times["hundred"].append(wall)
        times["hundred_fit_seconds"].append(sum(f["seconds"] for f in doc["fits"]))

    med = {k: statistics.median(v) for k, v in times.items()}
    result = {
        "commit": commit(),
        "settings": {
            "method": args.method,
            "model": args.model,
            "repeats": args.repeats,
            "interleaved": True,
            "count": args.count,
            "noise": args.noise,
            "samples": "1000-2000 (buckets 1024, 2048)",
            "python": platform.python_version(),
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average": list(os.getloadavg()),
        },
        "seconds": times,
        "median": med,
        "one_call_over_six_calls": med["one_call"] / med["six_calls"],
        "fits_per_second_hundred": args.count / med["hundred"],
        "fits_per_second_hundred_fits_only": args.count / med["hundred_fit_seconds"],
    }
    if not args.no_library:
        result["library_warm"] = _library(many, args.method, args.model)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps({k: v for k, v in result.items() if k != "seconds"}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
