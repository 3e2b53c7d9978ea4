"""Coverage of ``jadhesion fit``'s intervals on both generators across sensor-noise levels.

    python -m benchmarks.coverage_fit                      # defaults below → JSON + PNG
    python -m benchmarks.coverage_fit --per 12 --levels clean,0.5,1,2 --foreign-sensors clean,mild,realistic

For every set of recordings — ``ours/<scenario>/<level>`` from our simulator (``clean``: the
historical 5e-5 m/s white sensors; a number: that multiple of the realistic sensor model of
:mod:`jadhesion.data.sensors`) and ``foreign/start/<preset>`` from
:mod:`validation.foreign_generator` (no effects, walking-pace starts, written to CSV and read back
as the CLI does) and ``kinematic/<kind>`` from :mod:`validation.kinematic_generator` (prescribed
mainline, braking, walking-pace and constant-speed-sweep motions; random Polach parameters, vehicle,
logger rate 20–200 Hz and white speed noise 0.002–0.02 m/s as ``benchmarks.diagnose_null`` draws
them; written as its logger file and read back; braking fitted with ``--phase braking``) — the
fit's own path runs: the samples ``jadhesion fit`` keeps
(:func:`jadhesion.data.selected.selected_dataset`, its default ``--phase traction``: standstill
below 0.2 m/s, coasting and direction changes excluded; creep ``smoothed``, the default, and
``raw`` for comparison), global LM on the errors-in-variables
residual (:data:`jadhesion.identify.polach_fit.LM_RESIDUAL`), and the trust report
(:func:`jadhesion.identify.trust.fit_report`, HAC sandwich). Recorded per recording: the estimate
and stderr of every parameter; per set: coverage of the 90 % and 95 % intervals ``θ ± z·stderr``
(clipped to the box; a parameter fixed on a bound has no interval and counts as a miss unless the
truth is that bound), ``z = (estimate − truth)/stderr`` mean and sd (calibrated: 0 and 1; a mean far
from 0 is bias, an sd above 1 intervals too narrow), the initial slope ``(kA + kS)/2`` within 25 %
of the truth, median |μ0 error|; and for the curve's peak (μ_max and creep_opt at the fit's
reference speed, :mod:`jadhesion.identify.peak`) the coverage of the report's 90 % and 95 %
intervals against the true curve's peak at that speed (the generator's own ``k_eps``), and the
median and mean relative error.

Runs before 2026-11-24 (``coverage_fit.json`` at 8d588e4, ``coverage_fit_robust.json``,
``coverage_fit_truncated.json``) fitted every sample (:func:`jadhesion.data.dataset.to_dataset`),
standstill and coasting included, which ``jadhesion fit`` never does.
``results/coverage_fit_conditional.json`` is the same run before the trust block stopped
conditioning on parameters at a bound (commit 26731cc). ``--slip-law population`` fits with the
population slip law (:mod:`jadhesion.identify.slip_law`; ``coverage_fit_slip_law_*.json``);
``both`` (the default, as ``jadhesion fit``) with the normal law, each interval joined to the
population law's LM fit's (:func:`jadhesion.identify.trust.join_slip_laws`;
``coverage_fit_slip_law_both.json``). The
JSON records the git commit, every setting and ``os.getloadavg()``; the figure plots, per creep
option, the median relative error of the slope and of μ0 and the 90 % coverage of kS and μ0
against the speed-sensor noise sd (and of μ_max where the run recorded the peak).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

jax.config.update("jax_enable_x64", True)

from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.recording import load_recording  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.selected import selected_dataset  # noqa: E402
from jadhesion.data.sensors import CLEAN, REALISTIC  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify.batch_fit import fit_datasets  # noqa: E402
from jadhesion.identify.likelihood import SLIP_LAWS, as_slip_law, with_slip_law  # noqa: E402
from jadhesion.identify.peak import DERIVED  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach_batch  # noqa: E402
from jadhesion.identify.trust import fit_report, joined_interval  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES, adhesion_peak  # noqa: E402
from validation import kinematic_generator  # noqa: E402
from validation.foreign import physics  # noqa: E402
from validation.foreign_generator import generate, write  # noqa: E402

CREEPS = ("smoothed", "raw")
#: The samples fitted: ``jadhesion fit``'s default ``--phase``.
PHASE = "traction"
CHECKED = ("kS", "mu0")
Z = {"90": 1.6448536269514722, "95": 1.959963984540054}
RESULTS = Path(__file__).parent / "results"
#: Wheel-speed sensor sd [m/s] of the foreign presets for the figure's x axis
#: (validation/foreign/sensors.py: clean none — plotted at our clean level; mild white 1e-3, AR
#: 5e-4, quantum 1e-3; realistic drawn per recording, the geometric midpoints of its ranges).
FOREIGN_SD = {"clean": CLEAN.speed_sd(), "mild": 1.15e-3, "realistic": 2.8e-3}


def _recordings_ours(name, level, per, points):
    seeds = list(range(100, 100 + per))
    if level == "clean":
        return simulate_many(name, seeds, n_samples=points, sensors="clean")
    return simulate_many(name, seeds, n_samples=points, sensor_noise=float(level))


def foreign_starts(preset, per, tmp, rate=None, duration=30.0):
    """``(recording, ForeignRecording)`` of seeds ``0 … per − 1`` of the independent generator
    (no effects, walking-pace starts, sensor ``preset``, ``rate`` [Hz] or its random choice,
    ``duration`` [s]): written to CSV in ``tmp`` and read back as the CLI reads a user's file."""
    for seed in range(per):
        fr = generate(seed, effect="none", sensor=preset, profile="start", rate_hz=rate, duration_s=duration)
        yield load_recording(write(fr, Path(tmp) / f"{preset}_{seed}.csv")), fr


def kinematic_runs(kind, per, tmp, duration=60.0):
    """``(recording, truth)`` of ``per`` clean recordings of the kinematic generator's profile
    ``kind`` (seeds 0 … per − 1; random parameters, vehicle, rate and speed noise, module docstring),
    written as its logger file in ``tmp`` and read back as the CLI reads a user's file."""
    for seed in range(per):
        rng = np.random.default_rng([seed, kinematic_generator.KINDS.index(kind)])
        settings = kinematic_generator.random_settings(rng)
        rec = kinematic_generator.generate(seed, kind, duration_s=duration, **settings)
        path = kinematic_generator.write(rec, Path(tmp) / f"{kind}_{seed}.csv")
        yield load_recording(path), rec.truth


def _fits(datasets):
    shapes = {d.adhesion.shape for d in datasets}
    if len(shapes) == 1:
        stacked = jax.tree.map(lambda *a: jnp.stack(a), *datasets)
        fits = fit_polach_batch(stacked, "lm", jax.random.split(jax.random.key(0), len(datasets)))
        return [jax.tree.map(lambda a, i=i: a[i], fits) for i in range(len(datasets))]
    # lengths differ (the selection): padded to the command line's buckets, few programs (one per
    # length exhausted XLA's code memory: "LLVM ERROR: Unable to allocate section memory")
    return [r.fit for r in fit_datasets(datasets, "lm", jax.random.key(0))]


def _rows(datasets, truths, k_eps):
    """Per dataset: the LM fit's estimate, stderrs, hac lags and the report's peak (``derived``)
    beside the true curve's peak at the same speed (``k_eps``: the generator's true gradient
    constants, default the dataset's)."""
    rows = []
    for i, (d, f, t) in enumerate(zip(datasets, _fits(datasets), truths, strict=True)):
        rep = fit_report(d, f)
        true_k = d.k_eps if k_eps is None else k_eps[i]
        peak = adhesion_peak(jnp.asarray(t, float), true_k, rep["vehicle_speed"])
        rows.append(
            {
                "truth": [float(x) for x in t],
                "estimate": np.asarray(f.params, float).tolist(),
                "stderr": [rep["uncertainty"][p]["stderr"] for p in PARAM_NAMES],
                "hac_lags": rep["hac_lags"],
                "converged": bool(int(f.status) == 0),
                "vehicle_speed": rep["vehicle_speed"],
                "derived": rep["derived"],
                "derived_truth": dict(zip(DERIVED, (float(x) for x in peak), strict=True)),
                "peak_extrapolated": any(w["code"] == "peak_extrapolated" for w in rep["warnings"]),
            }
        )
    return rows


def score(recordings, truths, k_eps=None, creeps=CREEPS, slip_law="normal", phase=PHASE):
    """Per creep option, the :func:`_rows` of one set; with ``slip_law`` ``"both"`` (``jadhesion
    fit``'s default) the normal law's, each with the population law's fit as ``other`` (its
    ``estimate``, ``stderr``, ``derived``, ``converged``), whose intervals :func:`summarise` joins."""
    out = {}
    for creep in creeps:
        base = [selected_dataset(r, phase, creep=creep)[0] for r in recordings]
        law = "normal" if slip_law == "both" else slip_law
        rows = _rows([with_slip_law(d, law) for d in base], truths, k_eps)
        if slip_law == "both" and base[0].slip_sd is not None:
            others = _rows([as_slip_law(d, "population") for d in base], truths, k_eps)
            keys = ("estimate", "stderr", "derived", "converged")
            rows = [{**r, "other": {k: o[k] for k in keys}} for r, o in zip(rows, others, strict=True)]
        out[creep] = rows
    return out


def _interval(est, se, z, lo=0.0, hi=1.0):
    """``est ± z·se`` clipped to ``[lo, hi]``; the point ``est`` where ``se`` is ``None`` (fixed on a
    bound: the interval is the bound itself)."""
    if se is None:
        return [est, est]
    return [max(est - z * se, lo), min(est + z * se, hi)]


def _derived_interval(entry, z, name):
    """The report's ``z`` interval of a derived quantity (``creep_opt`` on the log scale, as
    :mod:`jadhesion.identify.peak` builds it); ``None`` without one."""
    value, se = entry["value"], entry["stderr"]
    if se is None or not np.isfinite(se):
        return None
    if name == "creep_opt":
        return [value * np.exp(-z * se / value), value * np.exp(z * se / value)]
    return _interval(value, se, z, hi=np.inf)


def _holds(interval, truth):
    """Whether ``interval`` holds ``truth`` (a point interval: within 1e-6); ``None`` is a miss."""
    if interval is None:
        return False
    if interval[0] == interval[1]:
        return abs(interval[0] - truth) <= 1e-6
    return interval[0] <= truth <= interval[1]


def _param_interval(row, j, z):
    """Parameter ``j``'s ``z`` interval of a row, joined to its ``other`` law's where it has one
    (:func:`jadhesion.identify.trust.joined_interval`, the fit's rule: a bound stays a bound)."""
    own = _interval(row["estimate"][j], row["stderr"][j], z)
    if "other" not in row or row["stderr"][j] is None:
        return own
    o = row["other"]
    theirs = None if o["stderr"][j] is None else _interval(o["estimate"][j], o["stderr"][j], z)
    return joined_interval(own, theirs, o["estimate"][j])


def _peak_interval(row, z, name):
    own = _derived_interval(row["derived"][name], z, name)
    if "other" not in row:
        return own
    o = row["other"]["derived"][name]
    return joined_interval(own, _derived_interval(o, z, name), o["value"])


def summarise(rows):
    """Coverage, z statistics, slope and μ0 accuracy of one set's rows."""
    est = np.array([r["estimate"] for r in rows])
    truth = np.array([r["truth"] for r in rows])
    slope, true_slope = (est[:, 0] + est[:, 1]) / 2, (truth[:, 0] + truth[:, 1]) / 2
    out = {
        "n": len(rows),
        "slope_within25": float(np.mean(np.abs(slope / true_slope - 1) <= 0.25)),
        "slope_rel_error_median": float(np.median(np.abs(slope / true_slope - 1))),
        "mu0_abs_error_median": float(np.median(np.abs(est[:, 2] - truth[:, 2]))),
        "hac_lags_median": float(np.median([r["hac_lags"] for r in rows])),
    }
    for p in CHECKED:
        j = PARAM_NAMES.index(p)
        se = [r["stderr"][j] for r in rows]
        for lv, z in Z.items():
            out[f"{p}_coverage{lv}"] = float(
                np.mean([_holds(_param_interval(r, j, z), r["truth"][j]) for r in rows])
            )
        zs = np.array(
            [(e - t) / s for e, s, t in zip(est[:, j], se, truth[:, j], strict=True) if s and np.isfinite(s)]
        )
        out[f"{p}_z_mean"] = float(zs.mean()) if zs.size else None
        out[f"{p}_z_sd"] = float(zs.std()) if zs.size else None
        out[f"{p}_on_bound"] = int(sum(s is None for s in se))
    for name in DERIVED:
        have = [r for r in rows if "derived" in r]
        if not have:
            continue
        for lv, z in Z.items():
            hits = [_holds(_peak_interval(r, z, name), r["derived_truth"][name]) for r in have]
            out[f"{name}_coverage{lv}"] = float(np.mean(hits))
        rel = [r["derived"][name]["value"] / r["derived_truth"][name] - 1 for r in have]
        out[f"{name}_rel_error_median"] = float(np.median(np.abs(rel)))
        out[f"{name}_rel_error_mean"] = float(np.mean(rel))
    if any("derived" in r for r in rows):
        out["peak_extrapolated"] = int(sum(r.get("peak_extrapolated", False) for r in rows))
    return out


def figure(summary, path):
    """Error and 90 % coverage against the speed-sensor noise sd, per generator and creep option."""
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.2))
    for gen, marker in (("ours", "o"), ("foreign", "s"), ("kinematic", "^")):
        for creep, ls in zip(CREEPS, ("-", "--"), strict=True):
            keys = [k for k in summary if k.startswith(gen + "/") and k.endswith("/" + creep)]
            pts = sorted(((summary[k]["noise_sd"], summary[k]) for k in keys), key=lambda p: p[0])
            if not pts:
                continue
            groups = {}
            for sd, s in pts:
                groups.setdefault(sd, []).append(s)
            xs = sorted(groups)

            def mean(key, groups=groups, xs=xs):
                return [np.mean([s[key] for s in groups[v]]) for v in xs]

            label = f"{gen}, LM {creep}"
            # the kinematic sets are profiles, not noise levels: points, each named, no line
            ls = "" if gen == "kinematic" else ls
            axes[0].plot(xs, mean("slope_rel_error_median"), marker + ls, label=label)
            axes[1].plot(xs, mean("mu0_abs_error_median"), marker + ls, label=label)
            axes[3].plot(xs, mean("slope_within25"), marker + ls, label=label)
            shown = CHECKED + tuple(n for n in DERIVED[:1] if f"{n}_coverage90" in pts[0][1])
            for i, p in enumerate(shown):
                axes[2].plot(
                    xs,
                    mean(f"{p}_coverage90"),
                    marker + ls,
                    color=f"C{3 * i + ('ours', 'foreign', 'kinematic').index(gen)}",
                    label=f"{p}, {label}",
                )
            if gen == "kinematic":
                panels = {
                    0: ("slope_rel_error_median",),
                    1: ("mu0_abs_error_median",),
                    2: tuple(f"{p}_coverage90" for p in shown),
                    3: ("slope_within25",),
                }
                for k in keys:
                    for i, names in panels.items():
                        for name in names:
                            at = (summary[k]["noise_sd"], summary[k][name])
                            axes[i].annotate(k.split("/")[1], at, fontsize=5)
    axes[0].axhline(0.25, color="k", lw=0.6)
    axes[2].axhspan(0.85, 0.95, color="0.85")
    axes[3].axhline(0.9, color="k", lw=0.6)
    titles = (
        "LM |slope error| / slope (median)",
        "LM |μ0 error| (median)",
        "90 % interval coverage (the fit's intervals)",
        "share of LM slopes within 25 %",
    )
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xscale("log")
        ax.set_xlabel("speed-sensor noise sd [m/s]")
        note = "(ours: mean of 3 scenarios; kinematic: per profile)"
        ax.set_title(f"{title}\n{note}", fontsize=9)
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="clean,0.5,1,2")
    p.add_argument("--scenarios", default=",".join(SCENARIOS))
    p.add_argument("--per", type=int, default=12, help="recordings per set")
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--foreign-sensors", default="clean,mild,realistic")
    p.add_argument("--foreign-rate", type=float, default=50.0)
    p.add_argument("--foreign-duration", type=float, default=30.0)
    p.add_argument("--kinematic", default=",".join(kinematic_generator.KINDS), help="kinematic profiles")
    p.add_argument("--kinematic-duration", type=float, default=60.0)
    p.add_argument("--save", default=str(RESULTS / "coverage_fit.json"))
    p.add_argument("--figure", default=str(RESULTS / "coverage_fit.png"))
    p.add_argument("--creeps", default=",".join(CREEPS), help="creep options to fit")
    p.add_argument(
        "--slip-law",
        default="both",
        choices=(*SLIP_LAWS, "both"),
        help="the fit's --slip-law; both (default, as jadhesion fit): normal, intervals joined to "
        "the population law's",
    )
    p.add_argument("--replot", action="store_true")
    args = p.parse_args(argv)
    if args.replot:
        figure(json.loads(Path(args.save).read_text())["summary"], args.figure)
        return
    doc = {"commit": commit(), "settings": vars(args), "results": {}, "summary": {}}
    start = time.perf_counter()

    def record(key, recordings, truths, noise_sd, k_eps=None, phase=PHASE):
        scored = score(recordings, truths, k_eps, tuple(args.creeps.split(",")), args.slip_law, phase)
        for creep, rows in scored.items():
            doc["results"][f"{key}/{creep}"] = rows
            doc["summary"][f"{key}/{creep}"] = {"noise_sd": noise_sd, **summarise(rows)}
        doc["wall_seconds"], doc["loadavg"] = time.perf_counter() - start, os.getloadavg()
        Path(args.save).write_text(json.dumps(doc, indent=1) + "\n")
        print(key, json.dumps(doc["summary"][f"{key}/smoothed"]), flush=True)

    for level in filter(None, args.levels.split(",")):
        sd = CLEAN.speed_sd() if level == "clean" else float(level) * REALISTIC.speed_sd()
        for name in filter(None, args.scenarios.split(",")):
            recs = _recordings_ours(name, level, args.per, args.points)
            record(f"ours/{name}/{level}", recs, [SCENARIOS[name].params] * args.per, sd)
    with tempfile.TemporaryDirectory() as tmp:
        for preset in filter(None, args.foreign_sensors.split(",")):
            pairs = list(foreign_starts(preset, args.per, tmp, args.foreign_rate, args.foreign_duration))
            truths = [[fr.truth["params"][k] for k in PARAM_NAMES] for _, fr in pairs]
            k_eps = [fr.truth["vehicle"]["k_eps"] for _, fr in pairs]
            record(f"foreign/start/{preset}", [r for r, _ in pairs], truths, FOREIGN_SD[preset], k_eps)
        for kind in filter(None, args.kinematic.split(",")):
            pairs = list(kinematic_runs(kind, args.per, tmp, args.kinematic_duration))
            truths = [[t["params"][k] for k in PARAM_NAMES] for _, t in pairs]
            k_eps = [physics.VEHICLES[t["vehicle"]].k_eps() for _, t in pairs]
            noise_sd = float(np.median([t["speed_noise_m_s"] for _, t in pairs]))
            phase = kinematic_generator.phase(kind)
            record(f"kinematic/{kind}", [r for r, _ in pairs], truths, noise_sd, k_eps, phase)
    figure(doc["summary"], args.figure)


if __name__ == "__main__":
    main()
