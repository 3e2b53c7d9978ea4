"""NIST StRD nonlinear regression: jadhesion's LM vs scipy's MINPACK LM, from both starts.

For each of the 27 problems and both starts: the minimum log relative error (LRE, digits of
agreement with the certified parameters, pass ≥ 4), LM steps, warm time, and the same for
``scipy.optimize.least_squares(method="lm")`` with an analytic (JAX) Jacobian. Compile time per
problem is reported separately. Usage: ``python -m benchmarks.bench_nist [--json] [--data DIR]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

from jadhesion.identify.lm import lm_solve  # noqa: E402
from validation.nist import DATA_DIR as DATA  # noqa: E402
from validation.nist import MODELS, load_problem, log_relative_error  # noqa: E402


def bench(problem):
    model = MODELS[problem.name]
    res = lambda b, d: model(d[0], b) - d[1]  # noqa: E731
    data = (jnp.asarray(problem.x), jnp.asarray(problem.y))
    jac = jax.jit(jax.jacfwd(lambda b: res(b, data)))
    fun = jax.jit(lambda b: res(b, data))
    rows = []
    for k, p0 in enumerate(problem.starts):
        p0 = jnp.asarray(p0)
        start = time.perf_counter()
        jax.block_until_ready(lm_solve(res, p0, data))
        first = time.perf_counter() - start
        start = time.perf_counter()
        out = jax.block_until_ready(lm_solve(res, p0, data))
        warm = time.perf_counter() - start
        rows.append(
            dict(
                problem=problem.name,
                start=k + 1,
                lre=float(log_relative_error(out.params, problem.certified).min()),
                steps=int(out.steps),
                ms=1e3 * warm,
                compile_s=first - warm,
                **scipy_lm(fun, jac, p0, problem),
            )
        )
    return rows


def scipy_lm(fun, jac, p0, problem):
    from scipy.optimize import least_squares

    f = lambda b: np.asarray(fun(jnp.asarray(b)))  # noqa: E731
    j = lambda b: np.asarray(jac(jnp.asarray(b)))  # noqa: E731
    f(p0), j(p0)
    start = time.perf_counter()
    out = least_squares(
        f, np.asarray(p0), jac=j, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=10000
    )
    return dict(
        scipy_lre=float(log_relative_error(out.x, problem.certified).min()),
        scipy_ms=1e3 * (time.perf_counter() - start),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    rows = [r for path in sorted(args.data.glob("*.dat")) for r in bench(load_problem(path))]
    ours = sum(r["lre"] >= 4 for r in rows)
    theirs = sum(r["scipy_lre"] >= 4 for r in rows)
    if args.json:
        print(json.dumps(dict(rows=rows, passed=ours, scipy_passed=theirs, total=len(rows)), indent=2))
        return
    cols = ("problem", "start", "lre", "steps", "ms", "compile_s", "scipy_lre", "scipy_ms")
    print("  ".join(f"{c:>10}" for c in cols))
    for r in rows:
        print("  ".join(f"{r[c]:>10.4g}" if isinstance(r[c], float) else f"{r[c]:>10}" for c in cols))
    print(f"LRE >= 4: jadhesion {ours}/{len(rows)}, scipy MINPACK {theirs}/{len(rows)}")


if __name__ == "__main__":
    main()
