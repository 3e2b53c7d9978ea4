"""Paper 000 reproduced: online Kiencke identification, Algorithm 1 vs 2, with Monte Carlo honesty.

Scenario (:func:`scenario`): ``K = 1200`` steps as in the paper's Figures 4–6; rail dry → normal →
wet (:data:`RAIL_SETS`) with changes before steps 401 and 801; creep sweep
``λ(k) = 0.135 + 0.115 sin(2πk/100)`` ∈ [0.02, 0.25], both sides of every optimum
``λ_m = 1/√p2`` (0.14, 0.10, 0.06); measured adhesion ``μ(k) = μ_true(λ(k)) + σ ε(k)``,
``ε ~ N(0, 1)``, ``σ = 0.002`` (≈0.5 % of the dry peak; at ``σ = 0.005`` no variant holds p2
within 1 %, so the paper's claims would be untestable).

Metrics (per run, then median and IQR over runs; ``None`` where more than the quantile's share of
runs never converged — the ``never_*`` fractions say how many):

- ``k_p1_1pct``, ``k_p2_1pct``, ``k_mumax_01pct``: first step ``k`` of the dry segment from which the
  relative error stays within 1 % (0.1 % for ``μ_m``) up to the first rail change (``_first``: the
  first step it is inside at all);
- ``k_track_change1`` / ``k_track_change2``: steps after the dry→normal / normal→wet change until
  p1 and p2 both stay within :data:`TRACK_TOL` until the next change / the end
  (``k_track_after_change``: both pooled);
- ``fluctuation``: RMS relative error of ``μ_m`` over the last :data:`WINDOW` steps of each segment
  (``fluctuation_p1``, ``fluctuation_p2`` likewise; ``fluctuation_dry``: first segment only).

The SNR interval (:func:`calibrate_snr`) is the range ``S`` takes on noise-only steps. Finding: ``S``
mostly measures the size of ``H``, and with ``η`` held at 1, ``H`` grows and ``S`` stays inside the
interval, so the step can lock ``η = η_max`` and stop tracking (see ``never_track_change2``).
``variants``: Algorithm 1-guarded (:func:`jadhesion.identify.online.algorithm1_guarded_params`),
whose hold ends when the prediction error leaves 3 noise sd (each run's own, :func:`run_guarded`).
"""

from __future__ import annotations

import os
from typing import Callable, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..data.creep_state import difference_sd
from ..identify import online as ol
from ..models.kiencke import DEFAULT_SLOPE, RAIL_SETS, kiencke_adhesion, kiencke_regressors
from ..plots.online import figure

N_STEPS = 1200
CHANGES = (400, 800)
RAILS = ("dry", "normal", "wet")
NOISE = 0.002
TRACK_TOL = 0.05
WINDOW = 200
PAPER = {
    "k_p1_1pct": 30,
    "k_p2_1pct": 250,
    "k_mumax_01pct": 230,
    "claim": "Algorithm 1 converges faster, fluctuates less and tracks rail changes faster "
    "than Algorithm 2 (Figs 4-6; noise level, Kp and SNR interval not published)",
}


class Scenario(NamedTuple):
    """Creep ``lam`` (K,), measured adhesion ``mu`` (…, K), true ``[p1, p2]`` per step (K, 2)."""

    lam: jax.Array
    mu: jax.Array
    truth: jax.Array


def scenario(
    key, runs=None, n_steps=N_STEPS, changes=CHANGES, rails=RAILS, noise=NOISE, a_s=DEFAULT_SLOPE
) -> Scenario:
    """The module docstring's scenario; ``runs`` noise realisations (leading axis) from ``key``."""
    k = jnp.arange(1, n_steps + 1)
    lam = 0.135 + 0.115 * jnp.sin(2.0 * jnp.pi * k / 100.0)
    segment = sum(((k > c).astype(jnp.int32) for c in changes), jnp.zeros_like(k))
    truth = jnp.array([tuple(RAIL_SETS[r]) for r in rails])[segment]
    clean = kiencke_adhesion(lam, truth[:, 0], truth[:, 1], a_s)
    shape = (n_steps,) if runs is None else (runs, n_steps)
    eps = jax.random.normal(key, shape, clean.dtype)
    return Scenario(lam, jnp.broadcast_to(clean, shape) + noise * eps, truth)


@jax.jit
def _batch(params, lam, mu):
    return jax.vmap(ol.identify, (None, None, 0))(params, lam, mu)


def run_batch(params, sc: Scenario) -> ol.OnlineInfo:
    """One vmapped, jitted call over the noise realisations of ``sc`` (``sc.mu`` (R, K))."""
    return _batch(params, sc.lam, sc.mu)


@jax.jit
def _batch_guarded(lam, mu):
    def one(m):
        return ol.identify(ol.algorithm1_guarded_params(difference_sd(m)), lam, m)

    return jax.vmap(one)(mu)


def run_guarded(sc: Scenario) -> ol.OnlineInfo:
    """Algorithm 1-guarded over the realisations of ``sc``, each run's hold limit from its own
    μ̂ noise (:func:`jadhesion.data.creep_state.difference_sd`, as on a recording)."""
    return _batch_guarded(sc.lam, sc.mu)


def calibrate_snr(key, runs=200, kp=ol.DEFAULT_KP, q=(0.025, 0.975)):
    """The default SNR interval: element-wise quantiles ``q`` of ``S`` over the dry segment
    (``k > 5``) of Algorithm 1 without its SNR step — ``S``'s range when only noise is acting."""
    sc = scenario(key, runs)
    s = run_batch(ol.make_params(0.251, 1.0, 1.0, 0.0, kp=kp), sc).snr[:, 5 : CHANGES[0]]
    lo, hi = jnp.quantile(s.reshape(-1, 2, 2), jnp.asarray(q), axis=0)
    return lo, hi


def _stay_index(ok):
    """Index from which ``ok`` (…, n) is true to the end; ``inf`` when its last entry is false."""
    suffix = np.flip(np.cumprod(np.flip(ok, -1), -1), -1).astype(bool)
    first = np.argmax(suffix, -1).astype(float)
    return np.where(suffix[..., -1], first, np.inf)


def _first_index(ok):
    return np.where(ok.any(-1), np.argmax(ok, -1).astype(float), np.inf)


def run_metrics(trace: ol.OnlineInfo, truth, a_s=DEFAULT_SLOPE) -> dict:
    """Per-run metrics (arrays over runs; ``inf`` = never) of the module docstring."""
    truth = np.asarray(truth)
    mu_true = a_s / (truth[:, 0] + 2.0 * np.sqrt(truth[:, 1]))
    err = {
        "p1": np.abs(np.asarray(trace.p1) / truth[:, 0] - 1.0),
        "p2": np.abs(np.asarray(trace.p2) / truth[:, 1] - 1.0),
        "mumax": np.abs(np.asarray(trace.mu_max) / mu_true - 1.0),
    }
    err = {k: np.nan_to_num(v, nan=np.inf) for k, v in err.items()}
    c0 = CHANGES[0]
    out = {}
    for name, tol, label in (
        ("p1", 0.01, "k_p1_1pct"),
        ("p2", 0.01, "k_p2_1pct"),
        ("mumax", 0.001, "k_mumax_01pct"),
    ):
        ok = err[name][:, :c0] <= tol
        out[label] = _stay_index(ok) + 1.0
        out[label + "_first"] = _first_index(ok) + 1.0
    bounds = list(CHANGES) + [truth.shape[0]]
    both = (err["p1"] <= TRACK_TOL) & (err["p2"] <= TRACK_TOL)
    track = [_stay_index(both[:, a:b]) + 1.0 for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    out["k_track_after_change"] = np.concatenate(track)
    out.update({f"k_track_change{i + 1}": t for i, t in enumerate(track)})
    windows = np.concatenate([np.arange(b - WINDOW, b) for b in bounds])
    for name, label in (("mumax", "fluctuation"), ("p1", "fluctuation_p1"), ("p2", "fluctuation_p2")):
        out[label] = np.sqrt(np.mean(err[name][:, windows] ** 2, -1))
    out["fluctuation_dry"] = np.sqrt(np.mean(err["mumax"][:, c0 - WINDOW : c0] ** 2, -1))
    return out


def _num(v):
    v = float(v)
    return v if np.isfinite(v) else None


def summarise(per_run: dict) -> dict:
    """Median, IQR ``[q25, q75]`` and never-converged fraction of each per-run metric."""
    out = {}
    for key, v in per_run.items():
        q25, q50, q75 = np.quantile(v, [0.25, 0.5, 0.75], method="inverted_cdf")
        out[key] = _num(q50)
        out[key + "_iqr"] = [_num(q25), _num(q75)]
        if key.startswith("k_"):
            out["never_" + key[2:]] = float(np.mean(~np.isfinite(v)))
    return out


def batch_ls(sc: Scenario, a_s=DEFAULT_SLOPE) -> dict:
    """Offline least squares ``Z = U x`` on each whole rail segment (the information floor)."""
    z, u = kiencke_regressors(jnp.broadcast_to(sc.lam, sc.mu.shape), sc.mu, a_s)
    bounds = [0, *CHANGES, sc.lam.shape[0]]
    rel = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        uu, zz = u[:, a:b], z[:, a:b]
        x = jnp.linalg.solve(jnp.einsum("rki,rkj->rij", uu, uu), jnp.einsum("rki,rk->ri", uu, zz)[..., None])[
            ..., 0
        ]
        true = np.asarray(sc.truth[a])
        mu = np.asarray(ol.peak_adhesion(x, a_s))
        rel.append(
            np.abs(
                np.stack(
                    [x[:, 0] / true[0], x[:, 1] / true[1], mu * (true[0] + 2 * np.sqrt(true[1])) / a_s], -1
                )
                - 1.0
            )
        )
    med = np.median(np.stack(rel, 1), 0)
    return {
        "segments": list(RAILS),
        **{f"{n}_relerr": med[:, i].tolist() for i, n in enumerate(("p1", "p2", "mu_max"))},
    }


def ablation_params() -> dict:
    """Algorithm 2 plus each of Algorithm 1's three ingredients, and Algorithm 1 minus each."""
    lo, hi = (0.251, 1.0), (0.971, 1.0)
    return {
        "A2": ol.make_params(*hi, 0.0, 0.0),
        "A2+range": ol.make_params(*lo, 0.0, 0.0),
        "A2+weight": ol.make_params(*hi, 1.0, 0.0),
        "A2+snr": ol.make_params(*hi, 0.0, 1.0),
        "A1": ol.make_params(*lo, 1.0, 1.0),
        "A1-range": ol.make_params(*hi, 1.0, 1.0),
        "A1-weight": ol.make_params(*lo, 0.0, 1.0),
        "A1-snr": ol.make_params(*lo, 1.0, 0.0),
    }


def run(runs=1000, plot_dir=None, progress: Optional[Callable[[int, int], None]] = None, seed=0) -> dict:
    """Monte Carlo over ``runs`` noise seeds per configuration; JSON-ready dict (module docstring).

    ``progress(done, total)`` (optional) is called after each configuration and the batch LS.
    """
    sc = scenario(jax.random.key(seed), runs)
    configs = {
        "1": ol.algorithm1_params(),
        "2": ol.algorithm2_params(),
        **ablation_params(),
        "rls_0.98": ol.rls_params(0.98),
    }
    total = len(configs) + 2
    summaries, bands = {}, {}
    for done, (name, params) in enumerate(configs.items(), 1):
        trace = run_batch(params, sc)
        summaries[name] = summarise(run_metrics(trace, sc.truth))
        if name in ("1", "2"):
            bands[name] = {
                f: np.quantile(np.asarray(getattr(trace, f)), [0.05, 0.5, 0.95], axis=0)
                for f in ("p1", "p2", "mu_max", "eta")
            }
        if progress:
            progress(done, total)
    guarded = summarise(run_metrics(run_guarded(sc), sc.truth))
    if progress:
        progress(total - 1, total)
    batch = batch_ls(sc)
    if progress:
        progress(total, total)
    result = {
        "algorithms": {"1": summaries["1"], "2": summaries["2"]},
        "paper": PAPER,
        "ablation": {k: summaries[k] for k in ablation_params()},
        "variants": {"1-guarded": guarded},
        "baselines": {"rls_0.98": summaries["rls_0.98"], "batch_ls": batch},
        "setup": {
            "runs": runs,
            "steps": N_STEPS,
            "changes": list(CHANGES),
            "rails": list(RAILS),
            "noise_sigma": NOISE,
            "track_tol": TRACK_TOL,
            "window": WINDOW,
            "kp": ol.DEFAULT_KP,
            "a_s": DEFAULT_SLOPE,
            "snr_lo": np.asarray(ol.DEFAULT_SNR_LO).tolist(),
            "snr_hi": np.asarray(ol.DEFAULT_SNR_HI).tolist(),
        },
    }
    if plot_dir is not None:
        os.makedirs(plot_dir, exist_ok=True)
        path = os.path.join(plot_dir, "online_kiencke.png")
        figure(bands, np.asarray(sc.truth)).savefig(path, dpi=120)
        result["plots"] = [path]
    return result
