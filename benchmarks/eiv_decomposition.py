"""Why the fit's intervals miss on noisy sensors: the LM bias split into its x and y sources.

    python -m benchmarks.eiv_decomposition --per 8 --sensors realistic,clean

For each scenario of our simulator (``--per`` recordings of ``--points`` samples, seeds 100…) the
global LM fit is run with the regressor (slip/creep, "x") and the target (μ̂, "y") swapped one at a
time between what the fit sees and the simulator's noise-free latent signals:

* x: ``latent`` (true slip), ``raw`` (difference of the recorded speeds), ``smoothed`` (the RTS
  smoother of :mod:`jadhesion.data.creep_state`, with the errors-in-variables expected curve —
  LM's default residual).
* y: ``latent`` (true μ), ``observer`` (the paper observer's μ̂, what the fit uses),
  ``observer_aware`` (the target stays μ̂ but the prediction is the observer's view of the curve,
  ``LP[E μ_adh] + (T − LP[T])/(m g r)`` as in the posterior's ``observer`` likelihood),
  ``zero_phase`` (μ̂ from the average of the forward and the time-reversed observer derivative:
  no lag to first order).

Recorded per combination: mean and sd over recordings of every parameter's error and the share of
initial slopes ``(kA + kS)/2`` within 25 %. A bias that appears with ``latent x`` is the target's
(observer lag), one that appears only with the measured x is the regressor's (errors in variables).
The JSON records the git commit, the settings and ``os.getloadavg()``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.dataset import to_dataset  # noqa: E402
from jadhesion.data.observer import lowpass_foh  # noqa: E402
from jadhesion.data.scenarios import SCENARIOS  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.data.vehicle import GRAVITY  # noqa: E402
from jadhesion.identify.global_lm import global_lm  # noqa: E402
from jadhesion.identify.likelihood import curve_moments  # noqa: E402
from jadhesion.identify.observer_view import lowpass, recording_observer_terms  # noqa: E402
from jadhesion.identify.polach_fit import LM_POP, LM_STARTS  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES  # noqa: E402

BOX = (jnp.zeros(5), jnp.ones(5))


def _residual_plain(theta, args):
    data, _ = args
    return curve_moments(theta, data)[0] - data.adhesion


def _residual_observer(theta, args):
    data, obs = args
    return lowpass(curve_moments(theta, data)[0], obs) + obs.torque_term - data.adhesion


@jax.jit
def _fit_plain(data, obs):
    return global_lm(
        _residual_plain,
        BOX,
        jax.random.key(0),
        (data, obs),
        n_starts=LM_STARTS,
        pop_size=LM_POP,
        search_iter=0,
    )[0].params


@jax.jit
def _fit_observer(data, obs):
    return global_lm(
        _residual_observer,
        BOX,
        jax.random.key(0),
        (data, obs),
        n_starts=LM_STARTS,
        pop_size=LM_POP,
        search_iter=0,
    )[0].params


def zero_phase_adhesion(rec):
    """μ̂ with the wheel-speed derivative averaged over the observer run forward and backward."""
    c, v = rec.columns, rec.vehicle
    t, t0 = jnp.asarray(c["time"]), v.observer_time_constant_s
    om = jnp.asarray(c["wheel_speed"]) / v.wheel_radius_m
    forward = (om - lowpass_foh(t, om, t0)) / t0
    back = -((om[::-1] - lowpass_foh(-t[::-1], om[::-1], t0)) / t0)[::-1]
    torque = jnp.asarray(c["traction_torque"])
    return (torque - v.wheelset_inertia_kgm2 * 0.5 * (forward + back)) / (
        v.axle_load_kg * GRAVITY * v.wheel_radius_m
    )


def _x(rec, kind):
    if kind == "latent":
        d = to_dataset(rec, creep="raw")
        lat = rec.latent
        return d._replace(slip=jnp.asarray(lat["slip_velocity"]), creep=jnp.asarray(lat["creepage"]))
    return to_dataset(rec, creep=kind)


def run(name, sensors, per, points):
    truth = np.asarray(SCENARIOS[name].params)
    recs = simulate_many(name, list(range(100, 100 + per)), n_samples=points, sensors=sensors)
    obs = [recording_observer_terms(r) for r in recs]
    out = {}
    for xk in ("latent", "raw", "smoothed"):
        xs = [_x(r, xk) for r in recs]
        for yk in ("latent", "observer", "observer_aware", "zero_phase"):
            if yk == "latent":
                ds = [
                    d._replace(adhesion=jnp.asarray(r.latent["adhesion"]))
                    for d, r in zip(xs, recs, strict=True)
                ]
            elif yk == "zero_phase":
                ds = [d._replace(adhesion=zero_phase_adhesion(r)) for d, r in zip(xs, recs, strict=True)]
            else:
                ds = xs
            fit = _fit_observer if yk == "observer_aware" else _fit_plain
            est = np.array([np.asarray(fit(d, o)) for d, o in zip(ds, obs, strict=True)])
            err = est - truth
            slope = (est[:, 0] + est[:, 1]) / 2 / ((truth[0] + truth[1]) / 2)
            out[f"x={xk}/y={yk}"] = {
                "bias": dict(zip(PARAM_NAMES, err.mean(axis=0).tolist(), strict=True)),
                "sd": dict(zip(PARAM_NAMES, err.std(axis=0).tolist(), strict=True)),
                "slope_within25": float(np.mean(np.abs(slope - 1) <= 0.25)),
            }
            print(
                name,
                sensors,
                xk,
                yk,
                {p: round(v, 3) for p, v in out[f"x={xk}/y={yk}"]["bias"].items()},
                out[f"x={xk}/y={yk}"]["slope_within25"],
                flush=True,
            )
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", default=",".join(SCENARIOS))
    p.add_argument("--sensors", default="realistic,clean")
    p.add_argument("--per", type=int, default=8)
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--save", default=str(Path(__file__).parent / "results" / "eiv_decomposition.json"))
    args = p.parse_args(argv)
    sha = commit()
    doc = {"commit": sha, "settings": vars(args), "results": {}}
    start = time.perf_counter()
    for sensors in args.sensors.split(","):
        for name in args.scenarios.split(","):
            doc["results"][f"{name}/{sensors}"] = run(name, sensors, args.per, args.points)
            doc["wall_seconds"], doc["loadavg"] = time.perf_counter() - start, os.getloadavg()
            Path(args.save).write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
