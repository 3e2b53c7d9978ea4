"""The error of every method against sensor-noise level, on both generators (issue 18 item 4).

    python -m benchmarks.methods_noise                         # defaults below → JSON + PNG
    python -m benchmarks.methods_noise --per 6 --levels clean,0.5,1,2 --foreign clean,mild,realistic

Sets of clean recordings (no effects): ``ours/<level>`` from our simulator, the three paper
scenarios in turn (``clean``: the historical 5e-5 m/s white sensors; a number: that multiple of the
realistic sensor model of :mod:`jadhesion.data.sensors`; 2000 samples), and ``foreign/<preset>``
from :mod:`validation.foreign_generator` (walking-pace starts, 30 s at a random 20–200 Hz, written
to CSV and read back as the CLI does). Each recording goes through the fit's own path: the samples
``jadhesion fit`` keeps (:func:`jadhesion.data.selected.selected_dataset`, its default ``--phase
traction``; smoothed creep) — results before 2026-11-24 (``methods_noise.json`` at 2b3af6b,
``methods_noise_least_squares.json``) fitted every sample — and is identified by every method of
the registry (:data:`jadhesion.identify.methods.METHODS`, their defaults, 300 iterations for the
population methods) and by the posterior as ``jadhesion posterior`` runs it by default (Gaussian
errors-in-variables likelihood tempered by 1/κ; 32 walkers, ``--steps``; its median).

Recorded per set and method: the median |μ0 error|, the median relative error of the initial slope
``(kA + kS)/2`` and the share within 25 %, the median wall time of a warm fit; the commit, the
settings and ``os.getloadavg()``. The figure plots the first two against the speed-sensor noise sd.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import warnings
from pathlib import Path

import jax
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

jax.config.update("jax_enable_x64", True)

from emcee.autocorr import AutocorrError  # noqa: E402

from benchmarks.coverage_fit import FOREIGN_SD, PHASE, foreign_starts  # noqa: E402
from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.selected import selected_dataset  # noqa: E402
from jadhesion.data.sensors import CLEAN, REALISTIC  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify.laplace import colour_check, initial_spread, lm_optimum  # noqa: E402
from jadhesion.identify.mcmc import sample_posterior  # noqa: E402
from jadhesion.identify.methods import METHODS  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES  # noqa: E402

RESULTS = Path(__file__).parent / "results"
SCENARIO_CYCLE = ("dry", "wet", "sand")
POSTERIOR = "posterior"


def _ours(level: str, per: int):
    for i in range(per):
        name = SCENARIO_CYCLE[i % len(SCENARIO_CYCLE)]
        kw = {"sensors": "clean"} if level == "clean" else {"sensor_noise": float(level)}
        rec = simulate_many(name, [200 + i], n_samples=2000, **kw)[0]
        yield rec, np.asarray(list(rec.truth["params"].values()))


def _foreign(preset: str, per: int, tmp: str):
    for rec, fr in foreign_starts(preset, per, tmp):
        yield rec, np.asarray(list(fr.truth["params"].values()))


def _posterior(data, steps: int, seed: int):
    theta0 = lm_optimum(data)
    kappa = colour_check(data, theta0)["kappa"]
    spread = np.asarray(initial_spread(theta0, data)) * np.sqrt(kappa)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AutocorrError)
        res = sample_posterior(
            data, np.asarray(theta0), steps=steps, seed=seed, spread=spread, weight=1.0 / kappa
        )
    return np.array([res.params[n]["median"] for n in PARAM_NAMES])


def _slope(p) -> float:
    return (p[0] + p[1]) / 2.0


def run_set(recordings, steps: int) -> dict:
    rows = {m: [] for m in (*METHODS, POSTERIOR)}
    for i, (rec, truth) in enumerate(recordings):
        data = selected_dataset(rec, PHASE)[0]
        for m in rows:
            if m == POSTERIOR:
                t0 = time.perf_counter()
                p = _posterior(data, steps, i)
            else:
                # compile outside the timing
                fit_polach(data, m, jax.random.key(i)).params.block_until_ready()
                t0 = time.perf_counter()
                p = np.asarray(fit_polach(data, m, jax.random.key(i)).params)
            seconds = time.perf_counter() - t0
            rows[m].append((abs(p[2] - truth[2]), _slope(p) / _slope(truth) - 1.0, seconds))
        jax.clear_caches()  # the smoother and posterior compile per length: free their code memory (LLVM)
    out = {}
    for m, r in rows.items():
        a = np.array(r)
        out[m] = {
            "mu0_abs_error_median": float(np.median(a[:, 0])),
            "slope_rel_error_median": float(np.median(np.abs(a[:, 1]))),
            "slope_within25": float(np.mean(np.abs(a[:, 1]) <= 0.25)),
            "seconds_median": float(np.median(a[:, 2])),
            "mu0_abs_error": a[:, 0].tolist(),
            "slope_rel_error": a[:, 1].tolist(),
        }
    return out


def figure(results: dict, path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for gen, ls, marker in (("ours", "-", "o"), ("foreign", "--", "s")):
        sets = {k: v for k, v in results.items() if k.startswith(gen + "/")}
        if not sets:
            continue
        xs = np.array([v["speed_sd"] for v in sets.values()])
        order = np.argsort(xs)
        for j, m in enumerate((*METHODS, POSTERIOR)):
            for ax, key in zip(axes, ("mu0_abs_error_median", "slope_rel_error_median"), strict=True):
                ys = np.array([v["methods"][m][key] for v in sets.values()])
                ax.plot(xs[order], ys[order], ls, marker=marker, color=f"C{j}", label=f"{m}, {gen}")
    axes[0].set_title("median |μ0 error|")
    axes[1].set_title("median |slope error| / slope, slope = (kA + kS)/2")
    axes[1].axhline(0.25, color="k", lw=0.8)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel("speed-sensor noise sd [m/s]")
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle("every method against sensor noise: our simulator (solid), independent generator (dashed)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per", type=int, default=6, help="recordings per set (ours: dry, wet, sand in turn)")
    p.add_argument("--levels", default="clean,0.5,1,2", help="our simulator's sensor levels")
    p.add_argument("--foreign", default="clean,mild,realistic", help="the independent generator's presets")
    p.add_argument("--steps", type=int, default=1500, help="posterior steps (32 walkers)")
    p.add_argument("--save", default=str(RESULTS / "methods_noise.json"))
    a = p.parse_args(argv)
    sha = commit()
    settings = {k: getattr(a, k) for k in ("per", "levels", "foreign", "steps")}
    settings["phase"] = PHASE
    settings["load_average_at_start"] = list(os.getloadavg())
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        levels = [lv for lv in a.levels.split(",") if lv]
        sd = {lv: CLEAN.speed_sd() if lv == "clean" else REALISTIC.speed_sd() * float(lv) for lv in levels}
        sets = [(f"ours/{lv}", _ours(lv, a.per), sd[lv]) for lv in levels]
        presets = [pr for pr in a.foreign.split(",") if pr]
        sets += [(f"foreign/{pr}", _foreign(pr, a.per, tmp), FOREIGN_SD[pr]) for pr in presets]
        for name, recs, sd in sets:
            results[name] = {"speed_sd": sd, "methods": run_set(recs, a.steps)}
            summary = "  ".join(
                f"{m} {v['mu0_abs_error_median']:.4f}/{v['slope_rel_error_median']:.2f}"
                for m, v in results[name]["methods"].items()
            )
            print(f"{name:20s} |μ0 err| / |slope err|: {summary}", flush=True)
    settings["load_average_at_end"] = list(os.getloadavg())
    save = Path(a.save)
    save.write_text(json.dumps({"commit": sha, "settings": settings, "results": results}, indent=1))
    figure(results, save.with_suffix(".png"))


if __name__ == "__main__":
    main()
