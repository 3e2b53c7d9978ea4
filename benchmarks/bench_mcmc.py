"""emcee posterior of the Polach parameters: speed and calibration.

    python benchmarks/bench_mcmc.py                    # 32 walkers x 5000 steps, 1000-point dry recording
    python benchmarks/bench_mcmc.py --coverage 100     # calibration study (synthetic + dry/wet/sand)
    python benchmarks/bench_mcmc.py --json

**Speed.** The same ``emcee.EnsembleSampler(vectorize=True)`` with the ensemble log-probability as
one jitted, vmapped JAX call versus a NumPy implementation of the same log-posterior (the peer), both
timed warm (a short warm-up run first, so JAX's compile is excluded and reported separately).

**Calibration.** (a) ``N`` synthetic datasets, truths drawn uniformly in an interior sub-box, iid
Gaussian noise σ = 0.013 (the sampler's model is exact, so the 90 % intervals should contain the
truth in 85–95 % of cases); (b) ``N // 4`` simulated recordings per paper scenario
(:func:`jadhesion.data.simulator.simulate_batch`; observer noise is filtered, hence correlated, so the
iid likelihood is misspecified there) with the paper's parameters as truth. Truths on a box face use
the one-sided interval reaching that face. A parameter counts as *identified* when its median 90 %
interval is narrower than a quarter of the box.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from jadhesion.cli.common import emit_json, table  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.simulator import simulate_batch, simulate_dataset  # noqa: E402
from jadhesion.identify.calibration import (QUANTITIES, binomial_band, coverage_study,  # noqa: E402
                                            synthetic_dataset)
from jadhesion.identify.ensemble import ChainTooShortWarning, run_ensemble  # noqa: E402
from jadhesion.identify.laplace import initial_spread, lm_optimum  # noqa: E402
from jadhesion.identify.likelihood import LOG_SCALE_BOUNDS, ensemble_log_prob  # noqa: E402
from jadhesion.identify.mcmc import initial_ball  # noqa: E402

TRUTH_LO, TRUTH_HI = np.array([0.3, 0.2, 0.25, 0.2, 0.4]), np.array([0.9, 0.8, 0.45, 0.6, 1.0])


def numpy_log_prob(data):
    """The Gaussian log-posterior of :mod:`jadhesion.identify.likelihood` in NumPy, (W, 6) → (W,)."""
    s, w, mu_obs = (np.asarray(x)[None, :] for x in (data.creep, data.slip, data.adhesion))
    k_eps, n = float(data.k_eps), s.shape[1]

    def log_prob(phi):
        ka, ks, mu0, a, b, ls = (phi[:, i:i + 1] for i in range(6))
        mu = np.maximum(mu0 * ((1 - a) * np.exp(-b * np.abs(w)) + a), 1e-12)
        eps = np.clip(k_eps * s / mu, -1e8, 1e8)
        model = (2 * mu / np.pi) * (ka * eps / (1 + (ka * eps) ** 2) + np.arctan(ks * eps))
        r = mu_obs - model
        ll = -n * ls[:, 0] - 0.5 * np.sum(r * r, axis=1) / np.exp(2 * ls[:, 0]) - 0.5 * n * np.log(2 * np.pi)
        inside = np.all((phi[:, :5] >= 0) & (phi[:, :5] <= 1), axis=1)
        inside &= (ls[:, 0] >= LOG_SCALE_BOUNDS[0]) & (ls[:, 0] <= LOG_SCALE_BOUNDS[1])
        out = np.where(inside, ll, -np.inf)
        return np.where(np.isfinite(out), out, -np.inf)

    return log_prob


def bench_speed(walkers, steps, n_points, seed=0):
    data = simulate_dataset("dry", seed, n_samples=n_points)
    theta0 = lm_optimum(data)
    rng = np.random.default_rng(seed)
    p0 = initial_ball(np.asarray(theta0), np.log(0.01), walkers, rng, (np.zeros(5), np.ones(5)),
                      np.asarray(initial_spread(theta0, data)))
    out = {"walkers": walkers, "steps": steps, "n_points": int(data.creep.shape[0])}
    for name, make in (("jax", lambda: ensemble_log_prob(data)), ("numpy", lambda: numpy_log_prob(data))):
        lp = make()
        t0 = time.perf_counter()
        lp(p0[: walkers // 2])
        out[f"{name}_first_call_s"] = time.perf_counter() - t0
        np.testing.assert_allclose(lp(p0), ensemble_log_prob(data)(p0), rtol=1e-9)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ChainTooShortWarning)
            run_ensemble(lp, p0, 20, seed)                                   # warm-up
            chain, diag = run_ensemble(lp, p0, steps, seed, burn=steps // 4)
        out[f"{name}_s"] = diag.seconds
        out[f"{name}_tau_max"] = float(np.max(diag.tau))
        out[f"{name}_acceptance"] = diag.acceptance
    out["speedup_numpy_over_jax"] = out["numpy_s"] / out["jax_s"]
    return out


def _row(label, report):
    return {"set": label, "n": report.n_datasets,
            **{q: report.coverage[0.9][q] for q in QUANTITIES},
            "s/dataset": report.seconds}


def bench_coverage(n, steps, walkers, seed=0, progress=True):
    opts = dict(walkers=walkers, steps=steps, burn=steps // 3, max_derived=1000)
    rng = np.random.default_rng(seed)
    thetas = [rng.uniform(TRUTH_LO, TRUTH_HI) for _ in range(n)]
    datasets = [synthetic_dataset(rng, t, n=300) for t in thetas]
    show = (lambda i: sys.stderr.write(f"\r  {i} datasets")) if progress else None
    reports = {"synthetic": coverage_study(datasets, thetas, seed=seed, progress=show, **opts)}
    per = max(n // 4, 4)
    for name, sc in SCENARIOS.items():
        batch = simulate_batch(name, list(range(1000 + seed, 1000 + seed + per)), n_samples=500)
        sets = [jax.tree_util.tree_map(lambda x, i=i: x[i], batch) for i in range(per)]
        reports[name] = coverage_study(sets, [np.asarray(sc.params)] * per, seed=seed, progress=show, **opts)
    if progress:
        sys.stderr.write("\n")
    return reports


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", type=int, default=32)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--coverage", type=int, default=0, metavar="N", help="synthetic datasets")
    parser.add_argument("--coverage-steps", type=int, default=1500)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    doc = {"speed": bench_speed(args.walkers, args.steps, args.points)}
    if args.coverage:
        reports = bench_coverage(args.coverage, args.coverage_steps, args.walkers, progress=not args.json)
        doc["coverage"] = {k: {"n": r.n_datasets, "coverage90": r.coverage[0.9],
                               "coverage50": r.coverage[0.5], "width90": r.width90,
                               "seconds_per_dataset": r.seconds} for k, r in reports.items()}
        doc["band99"] = {k: binomial_band(r.n_datasets, 0.9) for k, r in reports.items()}
    if args.json:
        emit_json(doc)
        return
    s = doc["speed"]
    print(f"{s['walkers']} walkers x {s['steps']} steps, {s['n_points']} points (warm; 2 shared cores, noisy):")
    print(f"  JAX   {s['jax_s']:7.2f} s   (first call incl. compile {s['jax_first_call_s']:.2f} s)")
    print(f"  NumPy {s['numpy_s']:7.2f} s   ratio NumPy/JAX = {s['speedup_numpy_over_jax']:.2f}")
    if args.coverage:
        print("\n90 % interval coverage (one-sided for truths on a box face):")
        print(table([_row(k, r) for k, r in reports.items()], ["set", "n", *QUANTITIES, "s/dataset"]))
        print("\nmedian 90 % interval width (identified: < 0.25 for the box parameters):")
        print(table([{"set": k, **r.width90} for k, r in reports.items()], ["set", *QUANTITIES]))
        for k, r in reports.items():
            ident = [q for q in QUANTITIES[:5] if r.width90[q] < 0.25]
            print(f"  {k}: identifies {', '.join(ident) or 'nothing'}; 99 % band for n={r.n_datasets}: "
                  f"{binomial_band(r.n_datasets, 0.9)}")


if __name__ == "__main__":
    main()
