"""emcee posterior of the Polach parameters: speed and calibration.

    python -m benchmarks.bench_mcmc                    # 32 walkers x 5000 steps, 1000-point dry recording
    python -m benchmarks.bench_mcmc --coverage 100     # calibration study (synthetic + dry/wet/sand)
    python -m benchmarks.bench_mcmc --no-speed --recordings 102 --likelihoods observer,ar1,gauss \
        --save benchmarks/results/mcmc_coverage.json       # likelihoods on simulated recordings
    python -m benchmarks.bench_mcmc --json

**Speed.** The same ``emcee.EnsembleSampler(vectorize=True)`` with the ensemble log-probability as
one jitted, vmapped JAX call versus a NumPy implementation of the same log-posterior (the peer), both
timed warm (a short warm-up run first, so JAX's compile is excluded and reported separately).

**Calibration.** (a) ``N`` synthetic datasets, truths drawn uniformly in an interior sub-box, iid
Gaussian noise σ = 0.013 (the sampler's model is exact, so the 90 % intervals should contain the
truth in 85–95 % of cases); (b) ``N // 4`` simulated recordings per paper scenario
(:func:`jadhesion.data.simulated_datasets.simulate_batch`; observer noise is filtered, hence
correlated, so the iid likelihood is misspecified there) with the paper's parameters as truth.
Truths on a box face use the one-sided interval reaching that face. A parameter counts as
*identified* when its median 90 % interval is narrower than a quarter of the box.

**Likelihoods on recordings** (``--recordings M``): ``M`` simulated 22E recordings (a third per
scenario, seeds 1000…, ``--recording-points`` samples each) with the paper's
parameters as truth, each sampled under every likelihood of ``--likelihoods``; coverage of the 90 %
and 50 % intervals per scenario and overall, the τ of every chain, and progress on stderr. The
JSON is rewritten after every recording (``--save``), so a long run can be inspected as it goes.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

from jadhesion.cli.common import emit_json, table  # noqa: E402
from jadhesion.data.dataset import to_dataset  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.simulated_datasets import (  # noqa: E402
    result_dataset,
    simulate_batch,
    simulate_dataset,
)
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify.ensemble import ChainTooShortWarning, run_ensemble  # noqa: E402
from jadhesion.identify.laplace import initial_spread, lm_optimum  # noqa: E402
from jadhesion.identify.likelihood import (  # noqa: E402
    LOG_SCALE_BOUNDS,
    batch_log_posterior,
    ensemble_log_prob,
)
from jadhesion.identify.mcmc import initial_ball  # noqa: E402
from jadhesion.identify.observer_view import recording_observer_terms  # noqa: E402
from validation.calibration import (  # noqa: E402
    QUANTITIES,
    binomial_band,
    coverage_study,
    synthetic_dataset,
)

TRUTH_LO, TRUTH_HI = np.array([0.3, 0.2, 0.25, 0.2, 0.4]), np.array([0.9, 0.8, 0.45, 0.6, 1.0])


def numpy_log_prob(data):
    """The Gaussian log-posterior of :mod:`jadhesion.identify.likelihood` in NumPy, (W, 6) → (W,)."""
    s, w, mu_obs = (np.asarray(x)[None, :] for x in (data.creep, data.slip, data.adhesion))
    k_eps, n = float(data.k_eps), s.shape[1]

    def log_prob(phi):
        ka, ks, mu0, a, b, ls = (phi[:, i : i + 1] for i in range(6))
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


def _per_call(fn, x, repeats=400):
    fn(x)
    t0 = time.perf_counter()
    for _ in range(repeats):
        fn(x)
    return (time.perf_counter() - t0) / repeats


def bench_speed(walkers, steps, n_points, seed=0, nuts=False):
    """Warm emcee timings (JAX and NumPy log-probability), compile time apart, and a profile of one
        step: emcee calls the log-probability twice per step (each half of the ensemble), so
        ``2 x steps x per-call time`` is the log-probability's share and the rest is emcee's own
        Python (stretch move, bookkeeping), measured directly with a trivial log-probability. The
    default likelihood on a recording's smoothed creep (errors in variables: the curve's expectation
    over the slip's law) is timed per call twice in the same run: with the slip law's nodes stored
    once (``with_node_slips``, what the sampler does) and evaluated on every call (before)."""
    data = simulate_dataset("dry", seed, n_samples=n_points)
    theta0 = lm_optimum(data)
    rng = np.random.default_rng(seed)
    p0 = initial_ball(
        np.asarray(theta0),
        np.log(0.01),
        walkers,
        rng,
        (np.zeros(5), np.ones(5)),
        np.asarray(initial_spread(theta0, data)),
    )
    out = {"walkers": walkers, "steps": steps, "n_points": int(data.creep.shape[0]), "likelihood": "gauss"}
    for name, make in (("jax", lambda: ensemble_log_prob(data)), ("numpy", lambda: numpy_log_prob(data))):
        lp = make()
        t0 = time.perf_counter()
        lp(p0)
        lp(p0[: walkers // 2])
        out[f"{name}_compile_s"] = time.perf_counter() - t0  # first calls (JAX: tracing + XLA)
        np.testing.assert_allclose(lp(p0), ensemble_log_prob(data)(p0), rtol=1e-9)
        out[f"{name}_call_ms"] = 1e3 * _per_call(lp, p0[: walkers // 2])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ChainTooShortWarning)
            chain, diag = run_ensemble(lp, p0, steps, seed, burn=steps // 4)
        out[f"{name}_s"] = diag.seconds
        out[f"{name}_tau_max"] = float(np.max(diag.tau))
        out[f"{name}_acceptance"] = diag.acceptance
        out[f"{name}_ess_min"] = float(np.min(diag.ess[:5]))
        out[f"{name}_logprob_share"] = 2 * steps * out[f"{name}_call_ms"] / 1e3 / diag.seconds
    out["speedup_numpy_over_jax"] = out["numpy_s"] / out["jax_s"]
    # emcee's own cost per step: the same sampler on a trivial (6-D Gaussian) log-probability.
    trivial = lambda p: -0.5 * np.sum(p * p, axis=1)  # noqa: E731
    _, diag = run_ensemble(trivial, p0, steps, seed)
    out["emcee_overhead_s"] = diag.seconds
    # jit dispatch: a jitted no-op-sized function of the same (W/2, 6) NumPy array.
    tiny = jax.jit(lambda p: p[:, 0])
    out["jit_dispatch_us"] = 1e6 * _per_call(lambda p: np.asarray(tiny(p)), p0[: walkers // 2], 2000)
    # the observer likelihood on the same recording length (JAX only; no NumPy peer)
    ((odata, obs),) = recording_datasets("dry", [seed], n_points)
    lp = ensemble_log_prob(odata, "observer", obs=obs)
    p_obs = np.column_stack([p0, np.full(walkers, 0.8)])
    t0 = time.perf_counter()
    lp(p_obs)
    lp(p_obs[: walkers // 2])
    out["observer_compile_s"] = time.perf_counter() - t0
    out["observer_call_ms"] = 1e3 * _per_call(lp, p_obs[: walkers // 2])
    # errors in variables: the smoothed creep's dataset of the same recording, nodes stored or not
    (recording,) = simulate_many("dry", [seed], n_samples=n_points)
    smoothed = to_dataset(recording)
    stored = ensemble_log_prob(smoothed)
    box = (jnp.zeros(5), jnp.ones(5), jnp.zeros(()))

    def per_call(phis):
        return np.asarray(batch_log_posterior(phis, smoothed, *box, "gauss", None, jnp.ones(())))

    np.testing.assert_allclose(stored(p0), per_call(p0), rtol=1e-12)
    out["eiv_call_ms"] = 1e3 * _per_call(stored, p0[: walkers // 2])
    out["eiv_nodes_per_call_ms"] = 1e3 * _per_call(per_call, p0[: walkers // 2])
    if nuts:
        from jadhesion.identify.mcmc import sample_nuts

        res = sample_nuts(data, np.asarray(theta0), warmup=500, samples=1000, seed=seed)
        out["nuts"] = {
            "warmup": 500,
            "samples": 1000,
            "seconds": res.seconds,
            "compile_s": res.compile_seconds,
            "ess_min": float(np.min(res.ess[:5])),
            "tau": res.tau.tolist(),
            "integration_steps": res.integration_steps,
            "step_size": res.step_size,
            "ess_per_s": float(np.min(res.ess[:5]) / res.seconds),
        }
        out["emcee_ess_per_s"] = out["jax_ess_min"] / out["jax_s"]
        out["nuts_over_emcee_ess_per_s"] = out["nuts"]["ess_per_s"] / out["emcee_ess_per_s"]
    return out


def _row(label, report):
    return {
        "set": label,
        "n": report.n_datasets,
        **{q: report.coverage[0.9][q] for q in QUANTITIES},
        "s/dataset": report.seconds,
    }


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


def recording_datasets(name, seeds, n_points):
    """Simulated recordings of a scenario: (datasets, observer terms), the dataset as the recording's
    columns give it (recorded creep, slip, speed, observer output)."""
    return [
        (result_dataset(r), recording_observer_terms(r))
        for r in simulate_many(name, seeds, n_samples=n_points)
    ]


def bench_recordings(m, likelihoods, steps, walkers, n_points, seed=0, save=None, progress=True):
    """Coverage of each likelihood over ``m`` simulated recordings (a third per scenario)."""
    import json

    per = max(m // len(SCENARIOS), 1)
    opts = dict(walkers=walkers, steps=steps, burn=steps // 3, max_derived=1000)
    doc = {
        "recordings": per * len(SCENARIOS),
        "per_scenario": per,
        "n_points": n_points,
        "walkers": walkers,
        "steps": steps,
        "burn": steps // 3,
        "seeds": [1000 + seed, 1000 + seed + per],
        "band99_90": binomial_band(per * len(SCENARIOS), 0.9),
        "band99_90_scenario": binomial_band(per, 0.9),
        "results": {},
    }
    sets = {
        name: recording_datasets(name, list(range(1000 + seed, 1000 + seed + per)), n_points)
        for name in SCENARIOS
    }
    t_start = time.perf_counter()
    total = len(likelihoods) * per * len(SCENARIOS)
    done = [0]
    for lik in likelihoods:
        doc["results"][lik] = {}
        for name, sc in SCENARIOS.items():
            taus, accs = [], []

            def note(i, result, name=name, lik=lik, taus=taus, accs=accs):
                taus.append(float(np.max(result.diagnostics.tau)))
                accs.append(result.diagnostics.acceptance)
                done[0] += 1
                if progress:
                    el = time.perf_counter() - t_start
                    sys.stderr.write(
                        f"\r  [{lik}] {name} {i + 1}/{per}   total {done[0]}/{total}, "
                        f"{el:.0f} s, ~{el / done[0] * (total - done[0]):.0f} s left   "
                    )
                    sys.stderr.flush()

            datasets, observers = zip(*sets[name], strict=True)
            report = coverage_study(
                list(datasets),
                [np.asarray(sc.params)] * per,
                seed=seed,
                observers=list(observers) if lik == "observer" else None,
                on_result=note,
                likelihood=lik,
                **opts,
            )
            doc["results"][lik][name] = {
                "n": report.n_datasets,
                "coverage90": report.coverage[0.9],
                "coverage50": report.coverage[0.5],
                "width90": report.width90,
                "hits90": report.hits[0.9].astype(int).tolist(),
                "tau_max_median": float(np.median(taus)),
                "tau_max_max": float(np.max(taus)),
                "kept_steps_over_tau_median": float((steps - steps // 3) / np.median(taus)),
                "acceptance_median": float(np.median(accs)),
                "seconds_per_recording": report.seconds,
            }
        hits = np.concatenate([np.array(doc["results"][lik][n]["hits90"]) for n in SCENARIOS])
        doc["results"][lik]["all"] = {
            "n": int(hits.shape[0]),
            "coverage90": dict(zip(QUANTITIES, hits.mean(axis=0).tolist(), strict=True)),
        }
        if save:
            doc["wall_seconds"] = time.perf_counter() - t_start
            with open(save, "w") as fh:
                json.dump(doc, fh, indent=1)
    if progress:
        sys.stderr.write("\n")
    doc["wall_seconds"] = time.perf_counter() - t_start
    if save:
        with open(save, "w") as fh:
            json.dump(doc, fh, indent=1)
    return doc


def print_recordings(doc):
    print(
        f"\n90 % coverage on {doc['recordings']} simulated recordings ({doc['n_points']} points, "
        f"{doc['walkers']} walkers x {doc['steps']} steps); 99 % band per scenario "
        f"{doc['band99_90_scenario']}, overall {doc['band99_90']}:"
    )
    rows = []
    for lik, per in doc["results"].items():
        for name, r in per.items():
            rows.append(
                {
                    "likelihood": lik,
                    "set": name,
                    "n": r["n"],
                    **r["coverage90"],
                    "tau": r.get("tau_max_median", float("nan")),
                }
            )
    print(table(rows, ["likelihood", "set", "n", *QUANTITIES, "tau"]))
    print("\nmedian 90 % interval width (identified: < 0.25 for the box parameters):")
    rows = [
        {"likelihood": lik, "set": name, **r["width90"]}
        for lik, per in doc["results"].items()
        for name, r in per.items()
        if "width90" in r
    ]
    print(table(rows, ["likelihood", "set", *QUANTITIES]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", type=int, default=32)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--coverage", type=int, default=0, metavar="N", help="synthetic datasets")
    parser.add_argument("--coverage-steps", type=int, default=1500)
    parser.add_argument(
        "--recordings",
        type=int,
        default=0,
        metavar="M",
        help="simulated recordings for the likelihood coverage study",
    )
    parser.add_argument("--likelihoods", default="observer,ar1,gauss")
    parser.add_argument("--recording-points", type=int, default=500)
    parser.add_argument("--save", default=None, help="write the recordings study JSON here")
    parser.add_argument("--no-speed", action="store_true")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--nuts", action="store_true", help="also NUTS (needs blackjax)")
    args = parser.parse_args(argv)
    doc = (
        {} if args.no_speed else {"speed": bench_speed(args.walkers, args.steps, args.points, nuts=args.nuts)}
    )
    if args.recordings:
        doc["recordings"] = bench_recordings(
            args.recordings,
            args.likelihoods.split(","),
            args.coverage_steps,
            args.walkers,
            args.recording_points,
            save=args.save,
            progress=True,
        )
    if args.coverage:
        reports = bench_coverage(args.coverage, args.coverage_steps, args.walkers, progress=not args.json)
        doc["coverage"] = {
            k: {
                "n": r.n_datasets,
                "coverage90": r.coverage[0.9],
                "coverage50": r.coverage[0.5],
                "width90": r.width90,
                "seconds_per_dataset": r.seconds,
            }
            for k, r in reports.items()
        }
        doc["band99"] = {k: binomial_band(r.n_datasets, 0.9) for k, r in reports.items()}
    if args.json:
        emit_json(doc)
        return
    if args.recordings:
        print_recordings(doc["recordings"])
    if args.no_speed:
        return
    s = doc["speed"]
    print(
        f"{s['walkers']} walkers x {s['steps']} steps, {s['n_points']} points (warm; 2 shared cores, noisy):"
    )
    print(
        f"  JAX   {s['jax_s']:7.2f} s warm  (compile {s['jax_compile_s']:.2f} s; "
        f"{s['jax_call_ms']:.3f} ms/call, log-prob share {100 * s['jax_logprob_share']:.0f} %)"
    )
    print(
        f"  NumPy {s['numpy_s']:7.2f} s       ({s['numpy_call_ms']:.3f} ms/call, log-prob share "
        f"{100 * s['numpy_logprob_share']:.0f} %)   ratio NumPy/JAX = {s['speedup_numpy_over_jax']:.2f}"
    )
    print(
        f"  emcee alone (trivial log-prob) {s['emcee_overhead_s']:.2f} s; jit dispatch "
        f"{s['jit_dispatch_us']:.0f} us/call; observer likelihood {s['observer_call_ms']:.3f} ms/call "
        f"(compile {s['observer_compile_s']:.2f} s)"
    )
    print(
        f"  errors in variables (smoothed creep): {s['eiv_call_ms']:.3f} ms/call with the slip law's "
        f"nodes stored, {s['eiv_nodes_per_call_ms']:.3f} ms/call evaluating them on every call"
    )
    if "nuts" in s:
        n = s["nuts"]
        print(
            f"  NUTS (blackjax): {n['seconds']:.2f} s warm for {n['warmup']} warm-up + {n['samples']} "
            f"draws (compile {n['compile_s']:.1f} s), min ESS {n['ess_min']:.0f} -> {n['ess_per_s']:.0f}"
            f"/s; emcee {s['emcee_ess_per_s']:.0f}/s; NUTS/emcee = {s['nuts_over_emcee_ess_per_s']:.2f}"
        )
    if args.coverage:
        print("\n90 % interval coverage (one-sided for truths on a box face):")
        print(table([_row(k, r) for k, r in reports.items()], ["set", "n", *QUANTITIES, "s/dataset"]))
        print("\nmedian 90 % interval width (identified: < 0.25 for the box parameters):")
        print(table([{"set": k, **r.width90} for k, r in reports.items()], ["set", *QUANTITIES]))
        for k, r in reports.items():
            ident = [q for q in QUANTITIES[:5] if r.width90[q] < 0.25]
            print(
                f"  {k}: identifies {', '.join(ident) or 'nothing'}; 99 % band for n={r.n_datasets}: "
                f"{binomial_band(r.n_datasets, 0.9)}"
            )


if __name__ == "__main__":
    main()
