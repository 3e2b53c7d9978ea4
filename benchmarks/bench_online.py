"""Benchmark: online Kiencke identification, RUNS noise seeds x 1200 steps in one vmapped call.

Compile time (first call) and warm time (best of ``--repeat`` further calls) are reported
separately. Goal: warm ≤ 1 s for 1000 runs x 1200 steps on a laptop-class CPU.

    python -m benchmarks.bench_online [--runs 1000] [--algorithm 1] [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import time

import jax

from jadhesion.cli.common import emit_json, table
from jadhesion.config import enable_x64


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=1000)
    p.add_argument("--algorithm", choices=("1", "2"), default="1")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)

    enable_x64()
    from jadhesion.experiments import online as ex
    from jadhesion.identify import online as ol

    params = ol.algorithm1_params() if args.algorithm == "1" else ol.algorithm2_params()
    sc = ex.scenario(jax.random.key(0), args.runs)
    t0 = time.perf_counter()
    jax.block_until_ready(ex.run_batch(params, sc))
    first = time.perf_counter() - t0
    warm = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(ex.run_batch(params, sc))
        warm.append(time.perf_counter() - t0)
    best = min(warm)
    steps = args.runs * sc.lam.shape[0]
    row = {"algorithm": args.algorithm, "runs": args.runs, "steps": int(sc.lam.shape[0]),
           "compile_s": first - best, "warm_s": best, "steps_per_s": steps / best,
           "goal_met": best <= 1.0, "device": str(jax.devices()[0]), "dtype": str(sc.mu.dtype)}
    if args.json:
        emit_json(row)
    else:
        print(table([row], list(row)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
