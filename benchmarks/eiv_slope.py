"""Errors in variables in LM: plain residual vs the expected curve over the smoothed slip.

    python -m benchmarks.eiv_slope                   # defaults below; JSON in benchmarks/results/
    python -m benchmarks.eiv_slope --per 8 --points 500 --foreign 8 --foreign-duration 30

For each recording the dataset is that of the samples ``jadhesion fit`` keeps
(``selected_dataset(recording, "traction")``: smoothed creep with ``slip_sd``; results before
2026-11-24, ``eiv_slope.json`` and ``eiv_slope_sd2.json``, used every sample) and
``fit --method lm`` runs once per residual: with the plain residual ``mu_adh(s, w) − mu_hat``
(:func:`jadhesion.identify.polach_residuals.polach_residual`, the fit before this change) and with the
errors-in-variables residual ``E[mu_adh] − mu_hat`` over ``w ~ N(slip, slip_sd²)``
(:func:`jadhesion.identify.polach_residuals.polach_eiv_residual`), and with LM's default since
then, ``lm``: the effective-variance pseudo-Huber residual of its two stages
(:func:`jadhesion.identify.polach_residuals.polach_lm_residual`; ``plain`` and ``eiv`` ignore the
second stage's noise scale, so they stay least squares). Sets:

* ``ours/<scenario>/<sensors>``: our simulator, the three paper scenarios, ``--per`` seeds each,
  ``--points`` samples, realistic sensors (and clean ones, where the correction must vanish);
* ``foreign/<profile>/<sensor>``: :mod:`validation.foreign_generator` (no effects), walking-pace
  ``start`` profiles (from standstill), ``--foreign`` seeds, ``--foreign-rate`` Hz,
  ``--foreign-duration`` s, written to CSV and read back by ``load_recording`` (what ``jadhesion
  fit`` sees).

``eiv_sd2`` (``--residuals``) is an experiment: the EIV residual with the slip sd doubled.

Recorded per fit: the initial slope ``(kA + kS)/2`` against the truth (within 25 %?), ``|μ0
error|``, the MAE of the fitted curve to μ̂, and the wall time of the fit (with compilation where
the selected length's bucket differs from the previous recording's; before 1005bff, where
``fit_polach`` began to pad, its length). The JSON records the git commit and every setting.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from benchmarks.coverage_fit import PHASE  # noqa: E402
from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.length_buckets import bucket_length  # noqa: E402
from jadhesion.data.recording import load_recording  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.selected import selected_dataset  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify import polach_fit, polach_residuals  # noqa: E402
from validation.foreign_generator import generate, write  # noqa: E402


def _inflated(factor):
    """The EIV residual with the smoother's slip sd multiplied by ``factor`` (an experiment: the
    smoothed sd understates the error under coloured sensor noise)."""

    def residual(theta, data):
        if data.slip_sd is None:
            return polach_residuals.polach_residual(theta, data)
        return polach_residuals.polach_eiv_residual(theta, data._replace(slip_sd=factor * data.slip_sd))

    return residual


RESIDUALS = {
    "plain": polach_residuals.polach_residual,
    "eiv": polach_residuals.polach_eiv_residual,
    "lm": polach_residuals.polach_lm_residual,
    "eiv_sd2": _inflated(2.0),
}
NAMES = ("kA", "kS", "mu0", "A", "B")


def fit_with(residual: str, datasets):
    """LM fits of ``datasets`` with the named residual (the jit caches are cleared on a switch)."""
    polach_fit.LM_RESIDUAL = RESIDUALS[residual]
    jax.clear_caches()
    fits, seconds = [], []
    for i, d in enumerate(datasets):
        if i and bucket_length(d.adhesion.shape[-1]) != bucket_length(datasets[i - 1].adhesion.shape[-1]):
            jax.clear_caches()  # a new length bucket compiles anew: free the old programs' code memory
        t0 = time.perf_counter()
        f = polach_fit.fit_polach(d, "lm", jax.random.key(0))
        params = np.asarray(f.params)
        seconds.append(time.perf_counter() - t0)
        fits.append((params, float(f.mae)))
    return fits, seconds


def score(fits, seconds, truths):
    slope = np.array([(p[0] + p[1]) / 2 for p, _ in fits])
    true_slope = np.array([(t[0] + t[1]) / 2 for t in truths])
    rel = slope / true_slope - 1
    return {
        "slope": slope.tolist(),
        "true_slope": true_slope.tolist(),
        "slope_rel_error": rel.tolist(),
        "slope_within25": (np.abs(rel) <= 0.25).tolist(),
        "mu0_abs_error": [abs(p[2] - t[2]) for (p, _), t in zip(fits, truths, strict=True)],
        "mae": [m for _, m in fits],
        "params": [p.tolist() for p, _ in fits],
        "seconds": seconds,
    }


def ours(per, points, sensors):
    for name, sc in SCENARIOS.items():
        seeds = list(range(3000, 3000 + per))
        sims = simulate_many(name, seeds, n_samples=points, sensors=sensors)
        datasets = [selected_dataset(r, PHASE)[0] for r in sims]
        yield f"ours/{name}/{sensors}", datasets, [np.asarray(sc.params)] * per


def foreign(n, rate, duration, sensor, profile, tmp):
    datasets, truths = [], []
    for seed in range(n):
        rec = generate(seed, effect="none", sensor=sensor, profile=profile, rate_hz=rate, duration_s=duration)
        path = write(rec, Path(tmp) / f"{profile}_{sensor}_{seed}.csv")
        datasets.append(selected_dataset(load_recording(path), PHASE)[0])
        truths.append(np.array([rec.truth["params"][k] for k in NAMES]))
    yield f"foreign/{profile}/{sensor}", datasets, truths


def summarise(block):
    return {
        "n": len(block["slope"]),
        "slope_within25": float(np.mean(block["slope_within25"])),
        "slope_rel_error_median": float(np.median(block["slope_rel_error"])),
        "slope_abs_rel_error_median": float(np.median(np.abs(block["slope_rel_error"]))),
        "mu0_abs_error_median": float(np.median(block["mu0_abs_error"])),
        "mae_median": float(np.median(block["mae"])),
        "seconds_median": float(np.median(block["seconds"][1:] or block["seconds"])),
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per", type=int, default=8, help="seeds per scenario (our simulator)")
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--clean", action="store_true", help="also our simulator with clean sensors")
    p.add_argument("--foreign", type=int, default=8, help="foreign-generator recordings per set")
    p.add_argument("--foreign-rate", type=float, default=50.0)
    p.add_argument("--foreign-duration", type=float, default=30.0)
    p.add_argument("--foreign-sensors", default="realistic,mild")
    p.add_argument("--profiles", default="start")
    p.add_argument("--residuals", default="plain,eiv,lm", help=f"of {', '.join(RESIDUALS)}")
    p.add_argument("--save", default="benchmarks/results/eiv_slope.json")
    args = p.parse_args(argv)
    t_start = time.time()
    default = polach_fit.LM_RESIDUAL
    sets = []
    sensor_sets = ["realistic"] + (["clean"] if args.clean else [])
    for s in sensor_sets:
        sets += list(ours(args.per, args.points, s))
    with tempfile.TemporaryDirectory() as tmp:
        for prof in args.profiles.split(","):
            for s in args.foreign_sensors.split(","):
                if args.foreign:
                    sets += list(
                        foreign(args.foreign, args.foreign_rate, args.foreign_duration, s, prof, tmp)
                    )
    results, summary = {}, {}
    for residual in args.residuals.split(","):
        for key, datasets, truths in sets:
            fits, seconds = fit_with(residual, datasets)
            block = score(fits, seconds, truths)
            results[f"{key}/{residual}"] = block
            summary[f"{key}/{residual}"] = summarise(block)
            sys.stderr.write(f"{key}/{residual}: {summary[f'{key}/{residual}']}\n")
    polach_fit.LM_RESIDUAL = default
    doc = {
        "commit": commit(),
        "settings": vars(args),
        "summary": summary,
        "results": results,
        "wall_seconds": time.time() - t_start,
    }
    Path(args.save).parent.mkdir(parents=True, exist_ok=True)
    Path(args.save).write_text(json.dumps(doc, indent=1))
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
