"""Timing of the identification stack on synthetic 22E dry-rail data (float64, CPU).

Times are taken after a warm-up call; the first call's extra time is reported as compilation.
Rows: improved-TLBO ms/iteration (pop 50, 1000 points) beside mealpy's TLBO and pyswarms' PSO when
installed; improved-TLBO identification to a target MAE; warm LM (global and single start) beside
scipy's ``least_squares`` on the same residuals; global-LM vs scipy random-start success rate;
batched fits per second (64 datasets x 1000 points).
Usage: ``python -m benchmarks.bench_optimisers [--json]``.
"""

from __future__ import annotations

import argparse
import json
import time

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

import jadhesion  # noqa: E402
from jadhesion.data.dataset import PolachDataset  # noqa: E402
from jadhesion.identify import ITLBO, fit_polach, fit_polach_batch, lm_solve, polach_mae, run  # noqa: E402
from jadhesion.identify.lm import box_lm, box_lm_queue  # noqa: E402
from jadhesion.identify.polach_fit import LM_POP, LM_STARTS, SEED_SAMPLES  # noqa: E402
from jadhesion.identify.polach_residuals import polach_residual  # noqa: E402
from jadhesion.status import Status  # noqa: E402

THETA = np.array([0.4288, 1.0, 0.3555, 0.3575, 0.1316])
NOISE = 0.0135  # N(0, σ) gives MAE ≈ 0.8 σ ≈ 0.0108, the paper's dry-rail error


def dataset(seed, n=1000):
    rng = np.random.default_rng(seed)
    k_eps = jadhesion.LOCO_22E.k_eps()
    v = rng.uniform(0.3, 1.0, n)  # ≈ 2.2 km/h mean
    s = np.exp(rng.uniform(np.log(1e-3), np.log(0.8), n))
    w = s * v
    mu = np.asarray(jadhesion.polach_adhesion(jnp.asarray(THETA), s, w, k_eps))
    mu = mu + NOISE * rng.standard_normal(n)
    return PolachDataset(*(jnp.asarray(a) for a in (s, w, mu, v)), jnp.asarray(k_eps))


def timed(fn, repeat=5):
    start = time.perf_counter()
    jax.block_until_ready(fn())
    first = time.perf_counter() - start
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - start)
    warm = float(np.median(times))
    return warm, first - warm


def numpy_residual(ds):
    s, w, mu_hat, k = (np.asarray(a) for a in (ds.creep, ds.slip, ds.adhesion, ds.k_eps))

    def res(theta):
        ka, ks, mu0, a, b = theta
        mu = np.maximum(mu0 * ((1 - a) * np.exp(-b * np.abs(w)) + a), 1e-12)
        eps = k * s / mu
        return 2 * mu / np.pi * (ka * eps / (1 + (ka * eps) ** 2) + np.arctan(ks * eps)) - mu_hat

    return res


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--trials", type=int, default=200, help="datasets for success rates")
    args = parser.parse_args()
    rows = []
    ds = dataset(0)
    box = (jnp.zeros(5), jnp.ones(5))
    key = jax.random.key(0)
    iters = 100

    warm, comp = timed(lambda: run(ITLBO, polach_mae, box, key, 50, iters, args=ds).best_f)
    rows.append(
        dict(
            name="itlbo ms/iteration (pop 50, n 1000)",
            value=1e3 * warm / iters,
            unit="ms",
            goal="<= 0.6",
            compile_s=comp,
        )
    )
    rows += external_baselines(ds)

    truth_mae = float(polach_mae(jnp.asarray(THETA), ds))
    target = 1.02 * truth_mae
    fit = fit_polach(ds, "itlbo", key, target=target, max_iter=1000)
    warm, comp = timed(lambda: fit_polach(ds, "itlbo", key, target=target, max_iter=1000).params)
    rows.append(
        dict(
            name=f"itlbo identification to MAE {target:.4g}",
            value=1e3 * warm,
            unit="ms",
            goal="<= 20",
            compile_s=comp,
            iterations=int(fit.iterations),
            evaluations=int(fit.evaluations),
        )
    )

    warm, comp = timed(lambda: fit_polach(ds, "lm", key).params)
    fit = fit_polach(ds, "lm", key)
    rows.append(
        dict(
            name=f"global LM ({LM_POP} random + {LM_STARTS} LM on {SEED_SAMPLES} pts, polish)",
            value=1e3 * warm,
            unit="ms",
            goal="<= 3",
            compile_s=comp,
            steps=int(fit.iterations),
        )
    )
    p0 = jnp.full(5, 0.5)
    warm, comp = timed(lambda: box_lm(polach_residual, p0, ds, box).params)
    rows.append(
        dict(
            name="projected LM single start (0.5,...)",
            value=1e3 * warm,
            unit="ms",
            compile_s=comp,
            steps=int(box_lm(polach_residual, p0, ds, box).steps),
        )
    )
    warm, comp = timed(lambda: lm_solve(polach_residual, p0, ds, box, rtol=1e-8, atol=1e-8).params)
    rows.append(
        dict(
            name="optimistix LM, sine map, single start",
            value=1e3 * warm,
            unit="ms",
            compile_s=comp,
            steps=int(lm_solve(polach_residual, p0, ds, box).steps),
        )
    )
    rows += scipy_rows(ds, args.trials)
    rows.append(success_rate(args.trials))
    rows += batched(64)

    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for r in rows:
            extra = {k: v for k, v in r.items() if k not in ("name", "value", "unit")}
            print(f"{r['name']:<48} {r['value']:>10.4g} {r['unit']:<6} {extra}")


def external_baselines(ds):
    rows = []
    f = numpy_residual(ds)
    try:
        from mealpy import FloatVar
        from mealpy.human_based import TLO

        problem = dict(
            obj_func=lambda t: float(np.mean(np.abs(f(t)))),
            minmax="min",
            log_to=None,
            bounds=FloatVar(lb=[0.0] * 5, ub=[1.0] * 5),
        )
        start = time.perf_counter()
        TLO.OriginalTLO(epoch=20, pop_size=50).solve(problem)
        rows.append(
            dict(
                name="mealpy OriginalTLO (TLBO) ms/iteration",
                value=1e3 * (time.perf_counter() - start) / 20,
                unit="ms",
            )
        )
    except ImportError:
        rows.append(
            dict(
                name="mealpy OriginalTLO (TLBO) ms/iteration",
                value=float("nan"),
                unit="ms",
                note="mealpy not installed",
            )
        )
    try:
        import pyswarms

        opt = pyswarms.single.GlobalBestPSO(
            50, 5, dict(c1=1.49618, c2=1.49618, w=0.7298), bounds=(np.zeros(5), np.ones(5))
        )
        start = time.perf_counter()
        opt.optimize(lambda x: np.array([np.mean(np.abs(f(t))) for t in x]), iters=20, verbose=False)
        rows.append(
            dict(
                name="pyswarms GlobalBestPSO ms/iteration",
                value=1e3 * (time.perf_counter() - start) / 20,
                unit="ms",
            )
        )
    except ImportError:
        rows.append(
            dict(
                name="pyswarms GlobalBestPSO ms/iteration",
                value=float("nan"),
                unit="ms",
                note="pyswarms not installed",
            )
        )
    return rows


def scipy_rows(ds, trials):
    from scipy.optimize import least_squares

    f = numpy_residual(ds)
    start = time.perf_counter()
    for _ in range(trials):
        out = least_squares(f, np.full(5, 0.5), bounds=(0, 1), xtol=1e-12, ftol=1e-12)
    return [
        dict(
            name="scipy least_squares (trf, 2-point jac)",
            value=1e3 * (time.perf_counter() - start) / trials,
            unit="ms",
            nfev=int(out.nfev),
        )
    ]


def success_rate(trials, points=1000):
    """Share of datasets on which a fit reaches the global basin: MAE within 0.1 % of the best of
    (global LM, scipy from a random start, box LM started at the truth). One global-LM run and one
    scipy run per dataset, ``trials`` datasets (different noise), all fits of ours in one call."""
    from scipy.optimize import least_squares

    stack = jax.tree.map(lambda *a: jnp.stack(a), *[dataset(1000 + i, points) for i in range(trials)])
    ours = np.asarray(fit_polach_batch(stack, "lm", jax.random.split(jax.random.key(1), trials)).mae)
    box = (jnp.zeros(5), jnp.ones(5))
    from_truth = jax.vmap(lambda d: box_lm(polach_residual, jnp.asarray(THETA), d, box).params)(stack)
    truth_basin = np.asarray(jax.vmap(polach_mae)(from_truth, stack))
    rng = np.random.default_rng(1)
    theirs = []
    for i in range(trials):
        f = numpy_residual(jax.tree.map(lambda a, i=i: a[i], stack))
        theirs.append(float(np.mean(np.abs(f(least_squares(f, rng.uniform(0, 1, 5), bounds=(0, 1)).x)))))
    best = np.minimum(np.minimum(ours, np.asarray(theirs)), truth_basin)
    ok = lambda m: np.mean(np.asarray(m) <= 1.001 * best)  # noqa: E731
    return dict(
        name=f"global basin reached: global LM / scipy random start ({trials} datasets)",
        value=float(ok(ours)),
        unit="",
        goal=">= 0.99",
        scipy=float(ok(theirs)),
    )


@jax.jit
def _plain_lm_batch(stack):
    """Plain LM from (0.5, ...) on every dataset of a stack (one vmapped call)."""
    box = (jnp.zeros(5), jnp.ones(5))
    return jax.vmap(lambda d: box_lm(polach_residual, jnp.full(5, 0.5), d, box))(stack)


def _plain_lm_queue(stack):
    """The same fits through the work queue (8 lanes)."""
    n = stack.adhesion.shape[0]
    return box_lm_queue(polach_residual, jnp.full((n, 5), 0.5), stack, (jnp.zeros(5), jnp.ones(5)))


def batched(n, points=1000):
    stack = jax.tree.map(lambda *a: jnp.stack(a), *[dataset(i, points) for i in range(n)])
    keys = jax.random.split(jax.random.key(2), n)
    label = f"({n} datasets x {points} pts"
    rows = []
    steps = _plain_lm_batch(stack).steps
    for name, fn in (("vmap", _plain_lm_batch), ("work queue", _plain_lm_queue)):
        warm, comp = timed(lambda fn=fn: fn(stack).params, repeat=3)
        rows.append(
            dict(
                name=f"batched plain LM, {name}, fits/s {label})",
                value=n / warm,
                unit="fits/s",
                goal=">= 2000",
                compile_s=comp,
                median_steps=float(jnp.median(steps)),
                max_steps=int(jnp.max(steps)),
            )
        )
    truth = jax.vmap(lambda d: polach_mae(jnp.asarray(THETA), d))(stack)
    for method, name, kw in (
        ("lm", "global lm (queue polish)", {}),
        ("itlbo", "itlbo, stall test (cap 300)", {}),
        ("itlbo", "itlbo to 1.02 x truth MAE", dict(target=1.02 * truth)),
    ):
        warm, comp = timed(
            lambda method=method, kw=kw: fit_polach_batch(stack, method, keys, **kw).params, repeat=3
        )
        fit = fit_polach_batch(stack, method, keys, **kw)
        rows.append(
            dict(
                name=f"batched {name} fits/s {label})",
                value=n / warm,
                unit="fits/s",
                goal=">= 50" if method == "itlbo" else "-",
                compile_s=comp,
                max_iterations=int(jnp.max(fit.iterations)),
                reached=float(jnp.mean(fit.reached)),
                converged=float(jnp.mean(fit.status == int(Status.CONVERGED))),
            )
        )
    return rows


if __name__ == "__main__":
    main()
