"""How well the smoother's ``slip_sd`` states the error of the smoothed slip, and what it costs LM.

    python -m benchmarks.slip_sd_calibration                  # defaults below → JSON
    python -m benchmarks.slip_sd_calibration --per 6 --sets dry,wet,sand,foreign

For clean recordings of our simulator (``dry``, ``wet``, ``sand`` at its realistic sensors, 2000
samples, seeds 100…) and of the independent generator (``foreign``: walking-pace starts, its
realistic sensors with coloured noise of correlation time 0.1–2 s, 30 s at a random 20–200 Hz,
written to CSV and read back as the CLI does), the smoothed slip of
:func:`jadhesion.data.dataset.to_dataset` is compared with the generator's true slip:
``ratio = rms(ŵ − w) / rms(slip_sd)`` (1 when the stated sd is right). Then LM
(:func:`jadhesion.identify.polach_fit.fit_polach`) runs three ways on the same dataset:

* ``stated`` — the fit as shipped (expected curve over ``N(ŵ, slip_sd²)``);
* ``oracle_sd`` — the same with ``slip_sd`` multiplied by that recording's true ``ratio`` (what a
  right sd would give: an upper bound on calibrating the sd, not a method — it uses the truth);
* ``no_expectation`` — Polach's curve at ``ŵ`` itself (``slip_sd`` dropped).

``foreign-coasting``: the independent generator's default runs (its random profiles, most with
coasting stretches; 60 s, seeds 100…, realistic sensors), where ``to_dataset`` scales the
smoother's sd by the recording's coasting (:func:`jadhesion.data.creep_state.coasting_sd_scale`);
``smoother_ratio`` is the same ratio for the smoother's own sd, before that scale.

Recorded per set: the ratios, the bias, sd and median |error| of every parameter, the share of fits
with the initial slope ``(kA + kS)/2`` within 25 % of the truth; plus the commit, the settings and
``os.getloadavg()``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from benchmarks.coverage_fit import foreign_starts  # noqa: E402
from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.creep_state import smooth_recording  # noqa: E402
from jadhesion.data.dataset import to_dataset  # noqa: E402
from jadhesion.data.recording import load_recording  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES  # noqa: E402
from validation.foreign_generator import generate, write  # noqa: E402

RESULTS = Path(__file__).parent / "results"
MODES = ("stated", "oracle_sd", "no_expectation")


def recordings(name: str, per: int, tmp: str):
    """``(recording, true params (5,), true slip (n,))`` of one set."""
    if name == "foreign":
        for rec, fr in foreign_starts("realistic", per, tmp):
            slip = fr.latent["wheel_speed_true"] - fr.latent["vehicle_speed"]
            yield rec, np.asarray(list(fr.truth["params"].values())), np.asarray(slip)
        return
    if name == "foreign-coasting":
        for seed in range(100, 100 + per):
            fr = generate(seed, effect="none", sensor="realistic")
            rec = load_recording(write(fr, Path(tmp) / f"coasting_{seed}.csv"))
            slip = fr.latent["wheel_speed_true"] - fr.latent["vehicle_speed"]
            yield rec, np.asarray(list(fr.truth["params"].values())), np.asarray(slip)
        return
    for rec in simulate_many(name, list(range(100, 100 + per)), n_samples=2000):
        yield rec, np.asarray(list(rec.truth["params"].values())), np.asarray(rec.latent["slip_velocity"])


def _slope(p) -> float:
    return (p[0] + p[1]) / 2.0


def run_set(name: str, per: int, tmp: str) -> dict:
    ratios, smoother_ratios, errors = [], [], {m: [] for m in MODES}
    for rec, truth, slip in recordings(name, per, tmp):
        ds = to_dataset(rec)
        if len(slip) != ds.slip.shape[0]:
            raise RuntimeError(f"{name}: the dataset has {ds.slip.shape[0]} rows, the truth {len(slip)}")
        err = np.asarray(ds.slip) - slip
        ratio = float(np.sqrt(np.mean(err**2) / np.mean(np.asarray(ds.slip_sd) ** 2)))
        ratios.append(ratio)
        smoother_sd = np.asarray(smooth_recording(rec).slip_sd)
        smoother_ratios.append(float(np.sqrt(np.mean(err**2) / np.mean(smoother_sd**2))))
        variants = {
            "stated": ds,
            "oracle_sd": ds._replace(slip_sd=ds.slip_sd * ratio, creep_sd=ds.creep_sd * ratio),
            "no_expectation": ds._replace(slip_sd=None, creep_sd=None),
        }
        for mode, d in variants.items():
            p = np.asarray(fit_polach(d, "lm", jax.random.key(0)).params)
            errors[mode].append((p - truth, abs(_slope(p) / _slope(truth) - 1.0) <= 0.25))
    out = {
        "sd_ratio": {"values": ratios, "median": float(np.median(ratios))},
        "smoother_ratio": {"values": smoother_ratios, "median": float(np.median(smoother_ratios))},
    }
    for mode, rows in errors.items():
        e = np.array([r[0] for r in rows])
        out[mode] = {
            "bias": dict(zip(PARAM_NAMES, e.mean(0).tolist(), strict=True)),
            "sd": dict(zip(PARAM_NAMES, e.std(0).tolist(), strict=True)),
            "median_abs_error": dict(zip(PARAM_NAMES, np.median(np.abs(e), 0).tolist(), strict=True)),
            "slope_within25": float(np.mean([r[1] for r in rows])),
        }
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per", type=int, default=6, help="recordings per set")
    p.add_argument("--sets", default="dry,wet,sand,foreign")
    p.add_argument("--save", default=str(RESULTS / "slip_sd_calibration.json"))
    a = p.parse_args(argv)
    settings = {"per": a.per, "sets": a.sets, "load_average_at_start": list(os.getloadavg())}
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.sets.split(","):
            results[name] = res = run_set(name, a.per, tmp)
            print(
                f"{name}: stated sd understates the error {res['sd_ratio']['median']:.2f}× (median; "
                f"the smoother's own {res['smoother_ratio']['median']:.2f}×)"
            )
            for mode in MODES:
                r = res[mode]
                print(
                    f"  {mode:15s} mu0 bias {r['bias']['mu0']:+.4f} sd {r['sd']['mu0']:.4f}"
                    f"  kS bias {r['bias']['kS']:+.3f}  slope within 25 % {r['slope_within25']:.0%}"
                )
    doc = {"commit": commit(), "settings": settings, "results": results}
    Path(a.save).write_text(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
