"""Coverage of ``jadhesion fit``'s 95 % intervals on simulated recordings.

For each of ``--n`` simulated recordings of a scenario (seeds ``0..n-1``, the simulator's default
sensor noise, the observer in the loop) the global LM fit and its trust report
(:func:`jadhesion.identify.trust.fit_report`, HAC sandwich) are computed, and we count how often the
true ``mu0`` and ``kS`` lie inside ``ci95``. The same count with the i.i.d. covariance shows what
ignoring the observer's colouring costs. A parameter fitted onto a bound has no interval and counts
as a miss. Target: 90–98 % (a binomial 95 % band around 95 % at n = 100 is about 90–99 %).
``z_mean``/``z_sd`` are the mean and spread of ``(estimate − truth)/stderr``: calibrated intervals
give about 0 and 1; a large mean with a small spread is a systematic bias (model or observer misfit)
that wide intervals happen to cover.

The default scenario is ``sand`` (true kS = 0.4089 inside the box; dry and wet put kS = 1 on its
bound). Rerun after the simulator changes with ``python -m benchmarks.coverage_fit``; results go to
``benchmarks/results/coverage_fit.json`` with the git commit and the settings.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from jadhesion.data.scenarios import get_scenario  # noqa: E402
from jadhesion.data.simulator import simulate_batch  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach_batch, polach_residual  # noqa: E402
from jadhesion.identify.trust import fit_report  # noqa: E402
from jadhesion.identify.uncertainty import Z95, covariance  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES  # noqa: E402

CHECKED = ("mu0", "kS")
RESULT = Path(__file__).parent / "results" / "coverage_fit.json"


def coverage(scenario="sand", n=100, samples=None, chunk=25):
    """Per checked parameter: HAC and i.i.d. hit counts, median HAC/i.i.d. stderr ratio, and the
    fits' statuses."""
    truth = np.asarray(get_scenario(scenario).params)
    hits = {p: {"hac": 0, "iid": 0} for p in CHECKED}
    ratios = {p: [] for p in CHECKED}
    zs = {p: [] for p in CHECKED}  # (estimate − truth) / HAC stderr
    statuses, lags = [], []
    for first in range(0, n, chunk):
        seeds = list(range(first, min(first + chunk, n)))
        data = simulate_batch(scenario, seeds, n_samples=samples)
        fits = fit_polach_batch(data, "lm", jax.random.split(jax.random.key(0), len(seeds)))
        for i in range(len(seeds)):
            d = jax.tree.map(lambda a: a[i], data)
            f = jax.tree.map(lambda a: a[i], fits)
            report = fit_report(d, f)
            statuses.append(int(f.status))
            lags.append(report["hac_lags"])
            r = polach_residual(f.params, d)
            jac = jax.jacfwd(polach_residual)(f.params, d)
            fixed = np.array([report["uncertainty"][p]["stderr"] is None for p in PARAM_NAMES])
            iid_sd = np.sqrt(np.diag(np.asarray(covariance(jac, r, fixed, hac=False)[0])))
            for p in CHECKED:
                j = PARAM_NAMES.index(p)
                u = report["uncertainty"][p]
                if u["ci95"] is not None and u["ci95"][0] <= truth[j] <= u["ci95"][1]:
                    hits[p]["hac"] += 1
                if np.isfinite(iid_sd[j]) and abs(float(f.params[j]) - truth[j]) <= Z95 * iid_sd[j]:
                    hits[p]["iid"] += 1
                if u["stderr"] is not None and np.isfinite(iid_sd[j]) and iid_sd[j] > 0:
                    ratios[p].append(u["stderr"] / iid_sd[j])
                if u["stderr"] is not None and np.isfinite(u["stderr"]):
                    zs[p].append((float(f.params[j]) - truth[j]) / u["stderr"])
    return (
        {
            p: {
                "coverage_hac": hits[p]["hac"] / n,
                "coverage_iid": hits[p]["iid"] / n,
                "median_stderr_ratio_hac_over_iid": (float(np.median(ratios[p])) if ratios[p] else None),
                "z_mean": float(np.mean(zs[p])) if zs[p] else None,
                "z_sd": float(np.std(zs[p])) if zs[p] else None,
            }
            for p in CHECKED
        },
        statuses,
        lags,
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="sand")
    parser.add_argument("--n", type=int, default=100, help="simulated recordings (default 100)")
    parser.add_argument("--samples", type=int, default=None, help="samples per recording")
    args = parser.parse_args()
    t0 = time.perf_counter()
    result, statuses, lags = coverage(args.scenario, args.n, args.samples)
    commit = subprocess.run(
        ["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=Path(__file__).parent
    ).stdout.strip()
    doc = {
        "commit": commit,
        "settings": {
            "scenario": args.scenario,
            "n": args.n,
            "samples": args.samples,
            "method": "lm",
            "interval": "95 %, HAC Newey-West, Andrews AR(1) lags",
        },
        "coverage": result,
        "converged": float(np.mean(np.asarray(statuses) == 0)),
        "hac_lags_median": float(np.median(lags)),
        "seconds": time.perf_counter() - t0,
    }
    RESULT.parent.mkdir(exist_ok=True)
    RESULT.write_text(json.dumps(doc, indent=2) + "\n")
    print(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
