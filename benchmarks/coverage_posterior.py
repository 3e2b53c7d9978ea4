"""Coverage of ``jadhesion posterior``'s 90 % intervals on two generators, per likelihood.

    python -m benchmarks.coverage_posterior --per 8 --steps 2000

Recordings: our simulator (dry, wet, sand; realistic sensors, ``--per`` seeds each, 40 s at 50 Hz)
and the independent generator of ``validation/foreign_generator.py`` (``3 × --per`` clean
recordings: no concealed effect, its own vehicles, profiles, rates and sensor noise). Each is
written as a CSV + sidecar and run through the command line in this process
(``jadhesion posterior FILE --json``), once per ``--likelihoods`` entry: a ``--likelihood`` name,
``:tempered`` appended for ``--temper`` (tempered by the residuals' colour 1/κ as auto does). The
default ``gauss:tempered,student:tempered`` runs the tempered Gaussian (what ``auto`` runs) and
the tempered Student-t, and adds ``tail_pick`` rows: per recording the run of the one the printed
tail check picks (Student-t where ``tempering.heavy_tails``; a candidate auto rule, measured and not
adopted: the same chains, so no further runs). Recorded per generator and likelihood
(``<likelihood>/own``: the posterior's own 90 % intervals, before ``posterior`` joins them with
LM's under the other slip law): the share of 90 % intervals holding the truth of kA, kS, μ0 and of
the derived μ_max, creep_opt (at the recording's median speed, from the true parameters; a truth on
a face of the prior box is left out of that parameter's share and counted), the median interval
width, the median |posterior median − truth|, and per recording the truth, the interval, the
median, the ``tempering`` block (κ, tail check), the status and the chain's run (slowest τ, steps,
acceptance, seconds; per cell: converged runs, median slowest τ and seconds); per recording, the
maximum-likelihood Student-t ν of the residuals at the truth (``tails_at_truth``; on the normal slip
law).
``--slip-law`` and ``--moves`` are passed to every run. The JSON records the git commit, the settings and
``os.getloadavg()``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize, stats

from benchmarks.provenance import commit
from jadhesion.cli import build_parser
from jadhesion.cli import main as cli
from jadhesion.cli.loading import load_dataset
from jadhesion.data.recording import load_recording
from jadhesion.identify.likelihood import SLIP_LAWS, curve_moments
from jadhesion.models.polach import PARAM_NAMES, adhesion_peak
from validation import foreign_generator

QUANTITIES = ("kA", "kS", "mu0", "mu_max", "creep_opt")
#: Parameters bounded by the prior box [0, 1]; a truth within FACE_TOL of a face is left out of
#: their coverage (a central 90 % interval cannot hold it) and counted in ``on_face``.
FACE_PARAMS, FACE_TOL = ("kA", "kS", "mu0"), 1e-3


def _ours(out: Path, per: int, offset: int = 0) -> list:
    cases = []
    for name in ("dry", "wet", "sand"):
        for seed in range(per):
            path = out / f"ours_{name}_{seed}.csv"
            with contextlib.redirect_stdout(io.StringIO()):
                cli(["simulate", "--scenario", name, "--seed", str(700 + offset + seed), "--out", str(path)])
            truth = json.loads(path.with_suffix(".truth.json").read_text())["params"]
            cases.append(("ours", f"{name}/{seed}", path, truth))
    return cases


def _foreign(out: Path, n: int, offset: int = 0) -> list:
    cases = []
    for i in range(n):
        rec = foreign_generator.generate(5100 + offset + i, effect="none")
        path = foreign_generator.write(rec, out / f"foreign_{i}.csv", truth=False)
        cases.append(("foreign", f"{i}", path, rec.truth["params"]))
    return cases


def _derived_truth(truth: dict, path: Path, speed: float) -> dict:
    """True μ_max and creep_opt at the speed the posterior reports them for."""
    theta = jnp.asarray([truth[n] for n in PARAM_NAMES])
    mu_max, creep_opt = adhesion_peak(theta, load_recording(path).vehicle.k_eps(), speed)
    return {"mu_max": float(mu_max), "creep_opt": float(creep_opt)}


def tails_at_truth(path: Path, truth: dict) -> dict:
    """The maximum-likelihood ν and scale s of Student-t noise on ``posterior``'s dataset at the true
    parameters, each residual on its errors-in-variables scale ``√(s² + Var[mu_adh])`` (the data
    behind the likelihood's fixed ν)."""
    _, data, _ = load_dataset(build_parser("posterior").parse_args(["posterior", str(path)]), path)
    mean, var = curve_moments(jnp.asarray([truth[n] for n in PARAM_NAMES]), data)
    r, var = np.asarray(data.adhesion) - np.asarray(mean), np.asarray(var)

    def nll(p):
        s = np.sqrt(np.exp(2.0 * p[1]) + var)
        return -np.sum(stats.t.logpdf(r / s, np.exp(p[0])) - np.log(s))

    start = [np.log(4.0), np.log(1.4826 * np.median(np.abs(r - np.median(r))))]
    nu, scale = np.exp(optimize.minimize(nll, start, method="Nelder-Mead").x)
    return {"nu_ml": float(nu), "scale_ml": float(scale)}


def _run(path: Path, entry: str, steps: int, walkers: int, slip_law: str, moves: str) -> dict | None:
    buf = io.StringIO()
    likelihood, _, mode = entry.partition(":")
    args = ["posterior", str(path), "--json", "--walkers", str(walkers), "--moves", moves]
    args += ["--slip-law", slip_law] + (["--steps", str(steps)] if steps > 0 else [])
    args += ["--likelihood", likelihood] + (["--temper"] if mode == "tempered" else [])
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        code = cli(args)
    return json.loads(buf.getvalue()) if code == 0 else None


def _scored(q: dict, truth: dict, suffix: str = "") -> dict:
    """A row scoring the 90 % intervals ``q05{suffix}``–``q95{suffix}`` of the posterior summary
    ``q`` (``""``: the reported ones; ``"_posterior"``: the posterior's own, where ``posterior``
    joined them with the other slip law's, else the reported) against ``truth``."""
    ends = {
        k: (q[k].get(f"q05{suffix}", q[k]["q05"]), q[k].get(f"q95{suffix}", q[k]["q95"])) for k in QUANTITIES
    }
    hit = {k: bool(lo <= truth[k] <= hi) for k, (lo, hi) in ends.items()}
    for k in FACE_PARAMS:  # a central interval never holds a face of the prior box
        if not FACE_TOL < truth[k] < 1 - FACE_TOL:
            hit[k] = None
    return {
        "truth": truth,
        "interval": {k: list(v) for k, v in ends.items()},
        "hit": hit,
        "width": {k: hi - lo for k, (lo, hi) in ends.items()},
        "median": {k: q[k]["median"] for k in QUANTITIES},
    }


def _chain(diag: dict) -> dict:
    """The sampler's run: the slowest coordinate's τ (steps), steps run, acceptance, wall time."""
    tau = [t for t in diag["tau"].values() if t is not None]  # the command writes NaN as null
    return {
        "tau_max": max(tau) if tau else None,
        "steps": diag["steps"],
        "acceptance": diag["acceptance"],
        "seconds": diag["seconds"],
    }


def _tail_pick_rows(rows: list) -> list:
    """Per recording, the tempered run of the likelihood the tail check picks (module docstring)."""
    runs = {(r["generator"], r["case"], r["likelihood"]): r for r in rows}
    out = []
    for (gen, case, lik), row in runs.items():
        other = runs.get((gen, case, "student:tempered"))
        if lik != "gauss:tempered" or other is None or "tempering" not in row:
            continue
        pick = other if row["tempering"]["heavy_tails"] else row
        out.append({**pick, "likelihood": "tail_pick", "picked": pick["likelihood"]})
    return out


def summarise(rows: list) -> dict:
    """Per ``generator/likelihood``: n, failed runs, 90 % coverage and median width per quantity."""
    out = {}
    for gen in sorted({r["generator"] for r in rows}):
        for lik in sorted({r["likelihood"] for r in rows}):
            sel = [r for r in rows if r["generator"] == gen and r["likelihood"] == lik]
            ok = [r for r in sel if r["hit"] is not None]
            if not sel:
                continue
            cell = {"n": len(sel), "failed": len(sel) - len(ok), "coverage90": {}, "median_width90": {}}
            cell["median_abs_error"] = {}
            cell["on_face"] = {q: sum(r["hit"][q] is None for r in ok) for q in FACE_PARAMS}
            ran = [r for r in ok if "chain" in r]
            if ran:  # how well the chains mixed: converged = 50 τ of every coordinate kept
                cell["converged"] = sum(r["status"] == "converged" for r in ran)
                cell["median_tau_max"] = float(np.median([r["chain"]["tau_max"] or np.nan for r in ran]))
                cell["median_seconds"] = float(np.median([r["chain"]["seconds"] for r in ran]))
            for q in QUANTITIES if ok else ():
                hits = [r["hit"][q] for r in ok if r["hit"][q] is not None]
                cell["coverage90"][q] = float(np.mean(hits)) if hits else None
                cell["median_width90"][q] = float(np.median([r["width"][q] for r in ok]))
                cell["median_abs_error"][q] = float(
                    np.median([abs(r["median"][q] - r["truth"][q]) for r in ok])
                )
            if lik == "tail_pick":
                cell["picked"] = {
                    p: sum(r["picked"] == p for r in sel) for p in sorted({r["picked"] for r in sel})
                }
            out[f"{gen}/{lik}"] = cell
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per", type=int, default=8, help="recordings per scenario of ours (foreign: 3×)")
    p.add_argument(
        "--steps",
        type=int,
        default=2000,
        help="steps per chain; 0: the command's default (5000, extended until 50 τ, up to 20000)",
    )
    p.add_argument("--moves", default="de", help="emcee's moves (posterior --moves)")
    p.add_argument("--walkers", type=int, default=32)
    p.add_argument("--likelihoods", default="gauss:tempered,student:tempered")
    p.add_argument("--slip-law", default="normal", choices=SLIP_LAWS)
    p.add_argument(
        "--seed-offset",
        type=int,
        default=0,
        help="added to every recording's seed (ours 700 + offset + i, foreign 5100 + offset + i): "
        "a fresh set of recordings",
    )
    p.add_argument(
        "--save", default=str(Path(__file__).parent / "results" / "coverage_posterior_student.json")
    )
    args = p.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    sha = commit()
    doc = {"commit": sha, "settings": vars(args), "rows": [], "tails_at_truth": []}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        cases = _ours(out, args.per, args.seed_offset) + _foreign(out, 3 * args.per, args.seed_offset)
        for gen, label, path, truth in cases:
            doc["tails_at_truth"].append({"generator": gen, "case": label, **tails_at_truth(path, truth)})
            for lik in args.likelihoods.split(","):
                res = _run(path, lik, args.steps, args.walkers, args.slip_law, args.moves)
                if res is None:
                    doc["rows"].append(
                        {"generator": gen, "case": label, "likelihood": lik, "truth": truth, "hit": None}
                    )
                    continue
                truth = {**truth, **_derived_truth(truth, path, res["vehicle_speed"])}
                q = {**res["params"], **res["derived"]}
                # the reported (both slip laws' joined) interval, and the posterior's own beside it
                for name, suffix in ((lik, ""), (f"{lik}/own", "_posterior")):
                    row = _scored(q, truth, suffix)
                    row.update(generator=gen, case=label, likelihood=name, tempering=res["tempering"])
                    row.update(status=res["status"], chain=_chain(res["diagnostics"]))
                    doc["rows"].append(row)
                    print(gen, label, name, row["hit"], flush=True)
            doc["summary"] = summarise(doc["rows"] + _tail_pick_rows(doc["rows"]))
            doc["wall_seconds"], doc["loadavg"] = time.perf_counter() - start, os.getloadavg()
            Path(args.save).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc["summary"], indent=1))


if __name__ == "__main__":
    main()
