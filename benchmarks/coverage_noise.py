"""Identification against sensor noise: LM slope recovery and posterior coverage, raw vs smoothed creep.

    python -m benchmarks.coverage_noise                         # defaults below, results JSON + PNG
    python -m benchmarks.coverage_noise --per 4 --levels clean,0.5,1,2 --steps 1500

For each noise level (``clean``: the historical 5e-5 m/s white sensors; a number: that multiple of
the realistic sensor model of :mod:`jadhesion.data.sensors`) and each paper scenario, ``--per``
recordings of ``--points`` samples from our simulator (no effects; the paper's parameters as truth)
are turned into datasets with ``creep="raw"`` and ``creep="smoothed"``
(:func:`jadhesion.data.dataset.to_dataset`) and identified by

* ``fit --method lm`` (:func:`jadhesion.identify.polach_fit.fit_polach`): initial slope
  ``(kA + kS)/2`` within 25 % of the truth, |μ0 error|;
* the emcee posterior with the ``--likelihood`` (default ``observer``; errors-in-variables when the
  dataset has ``slip_sd``): whether the 90 % intervals of kS, μ0, μ_max, creep_opt hold the truth.

The JSON (``benchmarks/results/coverage_noise.json``) records the git commit and every setting; the
figure (``coverage_noise.png``) plots slope error, μ0 error and 90 % coverage against noise level.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import jax
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

jax.config.update("jax_enable_x64", True)

from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.dataset import to_dataset  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.sensors import REALISTIC  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify.observer_view import recording_observer_terms  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach  # noqa: E402
from validation.calibration import QUANTITIES, binomial_band, coverage_study  # noqa: E402

CREEPS = ("raw", "smoothed")
COVERED = ("kS", "mu0", "mu_max", "creep_opt")


def _simulate(name, level, seeds, points):
    if level == "clean":
        return simulate_many(name, seeds, n_samples=points, sensors="clean")
    return simulate_many(name, seeds, n_samples=points, sensor_noise=float(level))


def run_level(level, per, points, steps, walkers, seed, likelihood="observer"):
    """Records of one noise level: per scenario and creep option, LM and posterior results."""
    out = {}
    for name, sc in SCENARIOS.items():
        truth = np.asarray(sc.params)
        sims = _simulate(name, level, list(range(2000 + seed, 2000 + seed + per)), points)
        obs = [recording_observer_terms(r) for r in sims]
        for creep in CREEPS:
            datasets = [to_dataset(r, creep=creep) for r in sims]
            lm = [np.asarray(fit_polach(d, "lm", jax.random.key(0)).params) for d in datasets]
            slope = np.array([(p[0] + p[1]) / 2 for p in lm])
            true_slope = (truth[0] + truth[1]) / 2
            report = coverage_study(
                datasets,
                [truth] * per,
                seed=seed,
                observers=obs if likelihood == "observer" else None,
                likelihood=likelihood,
                walkers=walkers,
                steps=steps,
                burn=steps // 3,
                max_derived=1000,
            )
            out[f"{name}/{creep}"] = {
                "lm_slope": slope.tolist(),
                "true_slope": true_slope,
                "lm_slope_within25": (np.abs(slope / true_slope - 1) <= 0.25).tolist(),
                "lm_mu0_abs_error": np.abs(np.array([p[2] for p in lm]) - truth[2]).tolist(),
                "hits90": report.hits[0.9].astype(int).tolist(),
                "coverage90": report.coverage[0.9],
                "width90": report.width90,
            }
            sys.stderr.write(
                f"  level {level} {name} {creep}: slope ok "
                f"{np.mean(out[f'{name}/{creep}']['lm_slope_within25']):.2f}, cov90 "
                f"{ {k: round(report.coverage[0.9][k], 2) for k in COVERED} }\n"
            )
    return out


def summarise(results):
    """Pooled over scenarios: per level and creep option, LM slope success, median μ0 error, and
    90 % coverage of each quantity."""
    table = {}
    for level, recs in results.items():
        for creep in CREEPS:
            rows = [v for k, v in recs.items() if k.endswith("/" + creep)]
            hits = np.concatenate([np.array(r["hits90"]) for r in rows])
            table[f"{level}/{creep}"] = {
                "n": int(hits.shape[0]),
                "lm_slope_within25": float(np.mean(sum((r["lm_slope_within25"] for r in rows), []))),
                "lm_slope_rel_error_median": float(
                    np.median(
                        np.concatenate([np.abs(np.array(r["lm_slope"]) / r["true_slope"] - 1) for r in rows])
                    )
                ),
                "lm_mu0_abs_error_median": float(np.median(sum((r["lm_mu0_abs_error"] for r in rows), []))),
                "coverage90": dict(zip(QUANTITIES, hits.mean(axis=0).tolist(), strict=True)),
            }
    return table


def figure(summary, levels, path):
    """Slope error, μ0 error and coverage against noise level (x: speed-sensor sd [m/s])."""
    x = [5e-5 if lv == "clean" else float(lv) * REALISTIC.speed_sd() for lv in levels]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for creep, style in zip(CREEPS, ("o--", "s-"), strict=True):
        rows = [summary[f"{lv}/{creep}"] for lv in levels]
        axes[0].plot(x, [r["lm_slope_rel_error_median"] for r in rows], style, label=f"LM, {creep}")
        axes[1].plot(x, [r["lm_mu0_abs_error_median"] for r in rows], style, label=f"LM, {creep}")
        for i, q in enumerate(COVERED):
            axes[2].plot(x, [r["coverage90"][q] for r in rows], style, color=f"C{i}", label=f"{q}, {creep}")
    axes[0].axhline(0.25, color="k", lw=0.6)
    axes[2].axhspan(0.85, 0.95, color="0.85")
    titles = (
        "LM |slope error| / slope (median)",
        "LM |μ0 error| (median)",
        "posterior 90 % coverage (observer lik.)",
    )
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xscale("log")
        ax.set_xlabel("speed-sensor noise sd [m/s]")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="clean,0.5,1,2")
    p.add_argument("--per", type=int, default=4, help="recordings per scenario and level")
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--steps", type=int, default=1500)
    p.add_argument("--walkers", type=int, default=32)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--likelihood", default="observer", help="posterior likelihood (default observer)")
    p.add_argument("--save", default="benchmarks/results/coverage_noise.json")
    p.add_argument("--figure", default="benchmarks/results/coverage_noise.png")
    p.add_argument("--replot", action="store_true", help="only redraw the figure from --save")
    args = p.parse_args(argv)
    levels = args.levels.split(",")
    if args.replot:
        with open(args.save) as fh:
            figure(json.load(fh)["summary"], levels, args.figure)
        return
    doc = {
        "commit": commit(),
        "settings": vars(args),
        "realistic_sensors": REALISTIC.as_dict(),
        "band99_90": binomial_band(args.per * len(SCENARIOS), 0.9),
        "results": {},
    }
    start = time.perf_counter()
    for level in levels:
        doc["results"][level] = run_level(
            level, args.per, args.points, args.steps, args.walkers, args.seed, args.likelihood
        )
        doc["summary"] = summarise(doc["results"])
        doc["wall_seconds"] = time.perf_counter() - start
        with open(args.save, "w") as fh:
            json.dump(doc, fh, indent=1)
    figure(doc["summary"], levels, args.figure)
    print(json.dumps(doc["summary"], indent=1))


if __name__ == "__main__":
    main()
