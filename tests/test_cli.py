"""The command line end to end: the DESIGN §3 contracts (JSON keys, exit code 2, nothing written)."""

import json
import subprocess
import sys
import types

import numpy as np
import pytest
from logger_data import stretches_si, swapped_stretches

from jadhesion import LOCO_22E, adhesion_peak, polach_adhesion
from jadhesion.cli import main
from jadhesion.cli.posterior_run import start_warning
from jadhesion.data.recording import save_recording
from jadhesion.identify.laplace import thinning
from jadhesion.identify.uncertainty import Z95
from jadhesion.report.text import table
from jadhesion.status import Status
from validation.foreign_generator import generate, write

STATUS_LABELS = {s.label for s in Status}


def jadhesion(*args, check=True):
    """The command in a process of its own, with this session's environment: its compilation
    cache (``conftest.py``), so a command loads the programs an earlier command of any worker
    compiled, as a user's second run does."""
    proc = subprocess.run(
        [sys.executable, "-m", "jadhesion", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    if check and proc.returncode != 0:
        raise AssertionError(f"exit {proc.returncode}: {proc.stderr}")
    return proc


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec") / "dry.csv"
    # 0.05 × the realistic sensors ≈ the historical clean level (5e-5 m/s): the contract and
    # accuracy checks below; at realistic noise LM's mu0 is off by ~0.01-0.03 (benchmarks/methods_noise).
    jadhesion("simulate", "--scenario", "dry", "--seed", "3", "--sensor-noise", "0.05", "--out", out)
    return out


def test_simulate_writes_recording_sidecar_and_truth(recording):
    assert recording.exists()
    assert recording.with_suffix(".json").exists()
    truth = json.loads(recording.with_name("dry.truth.json").read_text())
    assert truth["params"]["kA"] == pytest.approx(0.4288)


def test_fit_json_contract_and_accuracy(recording):
    proc = jadhesion("fit", recording, "--method", "lm", "--json")
    doc = json.loads(proc.stdout)
    assert set(doc) >= {"method", "params", "mae", "iterations", "evaluations", "seconds"}
    assert set(doc["params"]) == {"kA", "kS", "mu0", "A", "B"}
    floor = json.loads(recording.with_name("dry.truth.json").read_text())["envelope"]["true_param_mae"]
    # A least-squares fit cannot beat the noise floor by much, nor should it miss it by much.
    assert 0.95 * floor < doc["mae"] < 1.02 * floor
    assert doc["params"]["mu0"] == pytest.approx(0.3555, abs=0.01)
    # status and trust block (DESIGN §3 extensions)
    assert doc["status"] == "converged" and doc["converged"] is True
    assert set(doc["uncertainty"]) == {"kA", "kS", "mu0", "A", "B"}
    mu0 = doc["uncertainty"]["mu0"]
    assert 0 < mu0["stderr"] < 0.01  # μ0 is the best-determined parameter of a dry test
    assert mu0["ci95"][0] < doc["params"]["mu0"] < mu0["ci95"][1]
    hac = mu0["ci95_hac"]  # this law's own interval; ci95 joins the other slip law's (slip_law_check)
    assert hac[1] - hac[0] == pytest.approx(2 * 1.959964 * mu0["stderr"], rel=1e-6)
    assert mu0["ci95"][0] <= hac[0] and hac[1] <= mu0["ci95"][1]
    assert doc["slip_law_check"]["law"] == "population"
    corr = doc["correlation"]
    assert len(corr) == 5 and all(len(row) == 5 for row in corr)
    for i, row in enumerate(corr):
        for j, c in enumerate(row):
            assert c is None or (-1 - 1e-9 <= c <= 1 + 1e-9 and c == pytest.approx(corr[j][i]))
    assert corr[2][2] == pytest.approx(1.0)
    codes = {w["code"] for w in doc["warnings"]}
    assert codes <= {
        "at_bound",
        "weakly_identified",
        "undetermined",
        "not_converged",
        "few_samples",
        "peak_extrapolated",
    }
    # the curve's peak at the median speed, beside the true curve's peak there
    truth = json.loads(recording.with_name("dry.truth.json").read_text())["params"]
    theta = np.array([truth[n] for n in ("kA", "kS", "mu0", "A", "B")])
    true_peak = adhesion_peak(theta, LOCO_22E.k_eps(), doc["vehicle_speed"])
    for name, value in zip(("mu_max", "creep_opt"), true_peak, strict=True):
        d = doc["derived"][name]
        assert d["ci95"][0] < d["value"] < d["ci95"][1]
        assert d["value"] == pytest.approx(float(value), rel=0.05), name
    assert "not_converged" not in codes and "few_samples" not in codes
    for name, u in doc["uncertainty"].items():  # a parameter on a bound is said so, not given numbers
        assert {"stderr", "ci95", "stderr_hac", "stderr_jackknife"} <= set(u), name  # null, not absent
        on_bound = min(doc["params"][name], 1 - doc["params"][name]) < 1e-6
        assert (u["stderr"] is None) == (on_bound or name in _named(doc, "undetermined"))
        if on_bound:
            assert any(name in w["params"] for w in doc["warnings"] if w["code"] == "at_bound")
        else:  # free: a standard error within the box, or null and named undetermined
            assert u["stderr"] is None or u["stderr"] <= 1.0


def test_fit_human_output_says_whether_it_converged(recording, tmp_path):
    proc = jadhesion("fit", recording, "--method", "itlbo", "--max-iter", "3", "--plot", tmp_path / "plots")
    assert "NOT CONVERGED" in proc.stdout and "max_steps" in proc.stdout
    assert "warning [not_converged]" in proc.stdout
    assert (tmp_path / "plots" / "fit.png").stat().st_size > 10_000
    assert f"wrote {tmp_path / 'plots' / 'fit.png'}" in proc.stdout


def test_bad_row_exits_2_with_one_line_naming_file_column_row(recording, tmp_path):
    lines = recording.read_text().splitlines()
    header = lines[0].split(",")
    col = header.index("vehicle_speed")
    cells = lines[5].split(",")
    cells[col] = "fast"
    lines[5] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    before = set(tmp_path.iterdir())
    proc = jadhesion("fit", bad, "--json", check=False)
    assert proc.returncode == 2
    assert proc.stdout == ""
    message = proc.stderr.strip()
    assert "\n" not in message and "Traceback" not in message
    assert "bad.csv" in message and "vehicle_speed" in message and "row 5" in message
    assert set(tmp_path.iterdir()) == before


def test_missing_file_exits_2(tmp_path):
    proc = jadhesion("fit", tmp_path / "nope.csv", check=False)
    assert proc.returncode == 2 and "nope.csv" in proc.stderr


def test_reproduce_online_json_keys():
    proc = jadhesion("reproduce", "online", "--runs", "8", "--json")
    doc = json.loads(proc.stdout)
    a1, a2, paper = doc["algorithms"]["1"], doc["algorithms"]["2"], doc["paper"]
    # seed 000's convergence claims for Algorithm 1 (within 20 % of the paper's step counts) ...
    for k in ("k_p1_1pct", "k_p2_1pct", "k_mumax_01pct"):
        assert a1[k] is not None and a1[k] <= 1.2 * paper[k], k
    # ... and Algorithm 1 finds mu_max and follows a rail change faster than Algorithm 2
    assert a1["k_mumax_01pct"] < a2["k_mumax_01pct"]
    assert a1["k_track_after_change"] < a2["k_track_after_change"]
    assert a1["fluctuation"] > 0 and a2["fluctuation"] > 0


def test_reproduce_table2_json_rows_include_mcmc():
    proc = jadhesion(
        "reproduce", "table2", "--seeds", "1", "--mcmc-steps", "120", "--sensors", "realistic", "--json"
    )
    doc = json.loads(proc.stdout)
    assert doc["sensors"] == ["clean", "realistic"]
    keys = {
        "scenario",
        "method",
        "error",
        "iterations",
        "evaluations",
        "seconds",
        "params",
        "paper",
        "status",
    }
    cells = {(s, m) for s in ("dry", "wet", "sand") for m in ("itlbo", "tlbo", "pso", "lm", "mcmc")}
    rows = {sensors: [r for r in doc["rows"] if r["sensors"] == sensors] for sensors in doc["sensors"]}
    assert len(doc["rows"]) == 2 * len(cells)
    truth = {"dry": 0.3555, "wet": 0.2610}
    # The paper's conditions (clean sensors, creep from the speed difference): its numbers reproduced.
    assert {(r["scenario"], r["method"]) for r in rows["clean"]} == cells
    for row in rows["clean"]:
        assert set(row) >= keys, row["method"]
        assert row["creep"] == "raw" and row["status"] in STATUS_LABELS, row
        if row["method"] == "lm":  # least squares sits at the noise floor (MAE of the truth)
            assert 0.95 * row["floor"] < row["error"] < 1.02 * row["floor"], row
        elif row["method"] == "itlbo":  # the paper's method reaches the floor in its budget
            assert row["error"] < 1.05 * row["floor"] and row["reached"] >= 0.5, row
        elif row["method"] in ("tlbo", "pso"):
            assert row["error"] < 1.3 * row["floor"], row
        # μ0 is pinned on dry and wet rail; on sand (A = 0) it trades against B at these slips
        if row["method"] in ("lm", "itlbo") and row["scenario"] != "sand":
            assert row["params"]["mu0"] == pytest.approx(truth[row["scenario"]], abs=0.02), row
        if row["method"] in ("itlbo", "tlbo"):  # the paper reports both on every rail
            assert row["paper"] is not None and row["paper"]["iterations"] > 0
    for row in (r for r in rows["clean"] if r["method"] == "mcmc"):
        assert row["likelihood"] == doc["mcmc"]["likelihood"] and row["paper"] is None
        assert set(row["width90"]) >= {"kA", "kS", "mu0", "A", "B", "mu_max", "creep_opt"}
        if row["tau_max"] is None:  # a walker never moved in these few steps: no cost estimate
            assert row["iterations"] is None and row["seconds"] is None and not row["converged"]
        else:
            assert (
                row["iterations"] >= row["steps_run"] // 3
                and row["evaluations"] == row["iterations"] * row["walkers"]
            )
            assert row["seconds"] > 0
        assert 0.005 < row["error"] < 0.05
        assert row["status"] == ("converged" if row["converged"] else "max_steps")
    # Realistic sensors beside them (smoothed creep, as `fit` does): every cell, with its status; the
    # paper has no such numbers, and the sensors' noise adds to the floor of every scenario.
    assert {(r["scenario"], r["method"]) for r in rows["realistic"]} == cells
    clean_floor = {r["scenario"]: r["floor"] for r in rows["clean"] if r["method"] == "lm"}
    for row in rows["realistic"]:
        assert set(row) >= keys, row["method"]
        assert row["creep"] == "smoothed" and row["sensor_noise"] == 1.0 and row["paper"] is None
        assert row["status"] in STATUS_LABELS and np.isfinite(row["error"]), row
        if row["method"] == "lm":
            assert row["floor"] > clean_floor[row["scenario"]], row


def test_posterior_auto_likelihood_is_the_gaussian_tempered_by_the_residual_colour(recording):
    """The observer colours the residuals (lag-1 autocorrelation near 1 at 50 Hz): the default
    counts n/κ effective samples and says so; ``--likelihood observer`` stays on request."""
    proc = jadhesion("posterior", recording, "--walkers", "16", "--steps", "120", "--json")
    doc = json.loads(proc.stdout)
    temp = doc["tempering"]
    assert doc["likelihood"] == "gauss" and doc["likelihood_note"].startswith("auto: Gaussian tempered")
    assert temp["residual_rho"] > 0.5 and temp["kappa"] > 2.0
    assert temp["weight"] == pytest.approx(1.0 / temp["kappa"])
    assert temp["effective_samples"] == pytest.approx(temp["samples"] / temp["kappa"])
    assert set(doc["params"]) == {"kA", "kS", "mu0", "A", "B", "sigma"}
    assert doc["diagnostics"]["compile_seconds"] >= 0
    # the least-squares start carries its solver's status; only one that did not converge is warned of
    assert doc["lm_start_status"] == "converged"
    assert "lm_start_not_converged" not in [w["code"] for w in doc["warnings"]]
    stopped = start_warning(types.SimpleNamespace(status=int(Status.MAX_STEPS)))
    assert [w["code"] for w in stopped] == ["lm_start_not_converged"] and "max_steps" in stopped[0]["message"]
    check = doc["slip_law_check"]  # the other slip law's LM fit, beside this one law's posterior
    assert check["law"] == "population" and check["status"] == "converged"
    assert set(check["params"]) == {"kA", "kS", "mu0", "A", "B"} and set(check["derived"]) == {
        "mu_max",
        "creep_opt",
    }
    # the reported 90 % interval joins the posterior's own and LM's 90 % one under the other law
    summary, other = {**doc["params"], **doc["derived"]}, {**check["params"], **check["derived"]}
    outside = [
        n for n, v in other.items() if not summary[n]["q05_posterior"] <= v <= summary[n]["q95_posterior"]
    ]
    named = [n for w in doc["warnings"] if w["code"] == "slip_law_sensitive" for n in w["params"]]
    assert named == outside
    for n, v in other.items():
        q, theirs = summary[n], check["interval90"][n] or [v, v]
        assert q["q05"] == min(q["q05_posterior"], theirs[0]) and q["q95"] == max(
            q["q95_posterior"], theirs[1]
        )
        assert theirs[0] <= v <= theirs[1]
    assert "q05_posterior" not in doc["params"]["sigma"]  # noise parameters: the posterior's own
    # its kept programs are drop-ins for the library: test_programs.py
    args = ("--walkers", "16", "--steps", "60", "--likelihood", "observer", "--single-law", "--json")
    obs = json.loads(jadhesion("posterior", recording, *args).stdout)
    assert obs["likelihood"] == "observer" and obs["tempering"]["weight"] == 1.0
    assert set(obs["params"]) == {"kA", "kS", "mu0", "A", "B", "sigma", "rho"}


def test_posterior_of_an_oversampled_recording_samples_every_dth_sample(tmp_path, capsys):
    """The independent generator's steady run at 200 Hz, 30 s of it (5 446 samples used;
    residuals correlated over a hundred samples, κ ≈ 111): the default posterior evaluates every
    d-th sample weighted d/κ (:func:`jadhesion.identify.laplace.thinning`, here d = 3), the same
    n/κ effective samples at 1/d of the cost, and gives the posterior of all samples tempered by
    1/κ (``--likelihood gauss --temper``) within Monte Carlo noise: measured at 800 steps, medians
    within 0.07 of an interval's width, widths 1.00–1.10 of the full ones (sampling 3.2 s against
    8.5 s; the full 60 s run, 9 466 samples, d = 5: within 0.07 and 0.98–1.08). One slip law's
    chains (``--single-law``): the posterior's own intervals, not joined to an LM fit's. At 800
    steps (τ ≈ 35 steps) a width is Monte Carlo noise too: over seeds 0–3 (2026-12-03) μ_max's width
    ratio was 0.71, 0.93, 1.08 and 1.11, and a start moved by round-off moves it as much; the bound
    [0.6, 1.6] still catches a weight that misses the thinning's d (widths off by √d = 1.73)."""
    steady = generate(0, effect="none", sensor="mild", rate_hz=200.0, duration_s=30.0)
    path = write(steady, tmp_path / "steady.csv")
    docs = {}
    for name, extra in (("thinned", ()), ("all", ("--likelihood", "gauss", "--temper"))):
        assert main(["posterior", str(path), "--steps", "800", "--single-law", "--json", *extra]) == 0
        docs[name] = json.loads(capsys.readouterr().out)
    temp = docs["thinned"]["tempering"]
    every = thinning(temp["samples"], temp["kappa"])
    assert every >= 2 and temp["thinned"] == {"every": every, "samples": -(-temp["samples"] // every)}
    assert temp["weight"] == pytest.approx(every / temp["kappa"])
    assert "thinned" not in docs["all"]["tempering"]
    assert docs["all"]["tempering"]["weight"] == pytest.approx(1.0 / temp["kappa"])
    for name in ("kA", "kS", "mu0", "mu_max", "creep_opt"):
        a, b = ({**d["params"], **d["derived"]}[name] for d in (docs["thinned"], docs["all"]))
        width = b["q95"] - b["q05"]
        assert abs(a["median"] - b["median"]) <= 0.25 * width, (name, a, b)
        assert 0.6 <= (a["q95"] - a["q05"]) / width <= 1.6, (name, a, b)


def test_fit_warns_few_samples_in_process(tmp_path, capsys):
    """50 samples (≥ MIN_SAMPLES, < RECOMMENDED_SAMPLES): the fit runs and says its errors are rough."""
    rng = np.random.default_rng(0)
    creep = np.geomspace(1e-3, 0.3, 50)
    speed = np.full(50, 0.6)
    mu = np.asarray(
        polach_adhesion(np.array([0.43, 0.6, 0.36, 0.36, 0.13]), creep, creep * speed, LOCO_22E.k_eps())
    )
    mu = mu + 0.005 * rng.standard_normal(50)
    path = tmp_path / "few.csv"
    path.write_text(
        "creepage,vehicle_speed,adhesion\n"
        + "".join(f"{c},{v},{m}\n" for c, v, m in zip(creep, speed, mu, strict=True))
    )
    assert main(["fit", str(path), "--method", "lm", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "few_samples" in {w["code"] for w in doc["warnings"]}
    assert doc["uncertainty"]["mu0"]["ci95"][0] <= 0.36 <= doc["uncertainty"]["mu0"]["ci95"][1]


def _named(doc, *codes):
    return {n for w in doc["warnings"] if w["code"] in codes for n in w["params"]}


def _dataset_csv(path, creep, speed, mu):
    rows = np.column_stack([creep, speed, mu]).tolist()
    path.write_text("creepage,vehicle_speed,adhesion\n" + "".join(f"{c!r},{v!r},{m!r}\n" for c, v, m in rows))
    return path


def test_fit_of_one_creep_value_gives_no_standard_error_and_names_why(tmp_path, capsys):
    """Every sample at creep 0.02 and μ̂ 0.3: the data fix one point of the curve, neither its
    parameters nor its peak. Every standard error is null in JSON and "n/a" in the text, never
    inf (or the 10¹⁵⁴ an infinite variance once became), and each null is named by a warning."""
    path = _dataset_csv(tmp_path / "one.csv", np.full(400, 0.02), np.full(400, 10.0), np.full(400, 0.3))
    assert main(["fit", str(path), "--method", "lm", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    undetermined = _named(doc, "undetermined")
    for name, u in doc["uncertainty"].items():
        assert u["stderr"] is None and u["ci95"] is None
        assert name in undetermined | _named(doc, "at_bound")
    assert {"mu_max", "creep_opt"} <= undetermined
    assert all(d["stderr"] is None and d["ci95"] is None for d in doc["derived"].values())
    assert doc["creep"] == "given" and doc["slip_law"] is None  # the file's creepage, not smoothed
    assert main(["fit", str(path), "--method", "lm"]) == 0
    text = capsys.readouterr().out
    assert "inf" not in text.split() and "n/a" in text.split() and "warning [undetermined]" in text


def test_fit_says_when_the_creep_range_is_too_narrow_for_the_curve(tmp_path, capsys):
    """Creep held between 0.004 and 0.006 (a factor 1.5) cannot tell the curve's slope from its
    bend: narrow_creep_range. One creep value, 0.02, puts the fitted peak outside the data on one
    side or the other: peak_extrapolated too. Creep from 0.002 to 0.05 warns of neither."""
    rng = np.random.default_rng(1)
    theta, speed = np.array([0.43, 0.6, 0.36, 0.36, 0.13]), np.full(400, 0.6)

    def codes(name, creep, noise=0.002):
        mu = np.asarray(polach_adhesion(theta, creep, creep * speed, LOCO_22E.k_eps()))
        path = _dataset_csv(tmp_path / name, creep, speed, mu + noise * rng.standard_normal(creep.size))
        # one slip law (--single-law): the data's warnings are the subject
        assert main(["fit", str(path), "--method", "lm", "--single-law", "--json"]) == 0
        return {w["code"] for w in json.loads(capsys.readouterr().out)["warnings"]}

    assert "narrow_creep_range" in codes("held.csv", rng.uniform(0.004, 0.006, 400))
    assert {"narrow_creep_range", "peak_extrapolated"} <= codes("one.csv", np.full(400, 0.02), noise=0.0)
    assert "narrow_creep_range" not in codes("wide.csv", np.geomspace(0.002, 0.05, 400))


def test_fit_names_speed_columns_that_look_swapped(tmp_path, capsys):
    """Wheel and vehicle speed exchanged on both traction stretches of the logger test signal:
    the braking fit runs, and its warnings (Polach's and Kiencke's) open with the likely cause of
    the 700 of 1100 moving samples dropped as "torque and creep disagree"."""
    cols = swapped_stretches()
    path = save_recording(cols, LOCO_22E, tmp_path / "swapped.csv")
    for model in ("polach", "kiencke"):
        one_law = ["--single-law"] if model == "polach" else []  # the data's warnings are the subject
        argv = ["fit", str(path), "--model", model, "--method", "lm", "--phase", "braking", *one_law]
        argv += ["--json"]
        assert main(argv) == 0
        doc = json.loads(capsys.readouterr().out)
        assert doc["selection"]["counts"]["torque and creep disagree"] == 700
        first = doc["warnings"][0]
        assert first["code"] == "creep_sign" and "vehicle_speed swapped" in first["message"]


def test_misspelled_sidecar_keys_are_said_by_fit_online_and_posterior(tmp_path, capsys):
    """A sidecar with ``axle_lod_kg`` and ``wheel_radius``: each command that loads it says on
    stderr, once (not also as a note, as it once did), that the keys were ignored (with the key
    each likely meant) and lists it first in its JSON ``warnings``; fit echoes the vehicle numbers
    it used, here 22E's defaults under the sidecar's name. A correct sidecar: its numbers, no
    note."""
    path = save_recording(stretches_si(), LOCO_22E.replace(axle_load_kg=21000.0), tmp_path / "ok.csv")
    one_law = "--single-law"  # the sidecar is the subject here, not the slip laws
    assert main(["fit", str(path), "--method", "lm", one_law, "--json"]) == 0
    out = capsys.readouterr()
    assert "unknown key" not in out.err
    assert json.loads(out.out)["vehicle"] == {
        "name": "22E",
        "axle_load_kg": 21000.0,
        "wheel_radius_m": LOCO_22E.wheel_radius_m,
        "wheelset_inertia_kgm2": LOCO_22E.wheelset_inertia_kgm2,
    }
    path.with_suffix(".json").write_text(
        json.dumps({"name": "typo", "axle_lod_kg": 21000, "wheel_radius": 0.625})
    )
    note = (
        f"{path.with_suffix('.json')}: unknown key 'axle_lod_kg' ignored (did you mean 'axle_load_kg'?); "
        "unknown key 'wheel_radius' ignored (did you mean 'wheel_radius_m'?)"
    )
    for command, *flags in (
        ["fit", "--method", "lm", one_law],
        ["online"],
        ["posterior", "--walkers", "12", "--steps", "60", one_law],
    ):
        assert main([command, str(path), *flags, "--json"]) == 0
        out = capsys.readouterr()
        doc = json.loads(out.out)
        assert note in out.err and out.err.count("'axle_lod_kg'") == 1, (command, out.err)  # said once
        first = doc["warnings"][0]
        assert first["code"] == "sidecar_unknown_key" and note in first["message"], command
        assert first["params"] == ["axle_lod_kg", "wheel_radius"]
        if command == "fit":
            vehicle = doc["vehicle"]
    assert vehicle == {
        "name": "typo",
        "axle_load_kg": LOCO_22E.axle_load_kg,
        "wheel_radius_m": LOCO_22E.wheel_radius_m,
        "wheelset_inertia_kgm2": LOCO_22E.wheelset_inertia_kgm2,
    }


def test_fit_slip_law_population_on_a_steady_start(tmp_path):
    """Our simulator's dry start at its realistic sensors: the slips crowd within ~1.7 of their sds
    and the smoother's error there is classical (its mean over one true slip ~0), so the normal
    law draws LM's μ0 up (seed 700: 0.3666 against a true 0.3555, measured; its HAC interval alone
    misses it) and the population law much less (0.3597). Each fit also fits the other law by LM
    and joins its 95 % intervals to that law's, which then hold the true μ0; ``--single-law``
    skips that. ``--creep raw`` has no slip law: said on stderr, ``slip_law`` null, no check."""
    rec = tmp_path / "dry.csv"
    jadhesion("simulate", "--scenario", "dry", "--seed", "700", "--out", rec)
    mu0 = json.loads(rec.with_name("dry.truth.json").read_text())["params"]["mu0"]
    docs = {
        law: json.loads(jadhesion("fit", rec, "--method", "lm", "--json", "--slip-law", law).stdout)
        for law in ("normal", "population")
    }
    assert {law: d["slip_law"] for law, d in docs.items()} == {"normal": "normal", "population": "population"}
    assert all("crowded_slips" in {w["code"] for w in d["warnings"]} for d in docs.values())
    error = {law: abs(d["params"]["mu0"] - mu0) for law, d in docs.items()}
    assert error["population"] < 0.6 * error["normal"], error
    # each fit checks the other law by the same LM: its 95 % intervals join both, and hold the truth
    for law, other in (("normal", "population"), ("population", "normal")):
        check = docs[law]["slip_law_check"]
        assert check["law"] == other and check["status"] == "converged"
        assert check["params"] == pytest.approx(docs[other]["params"], rel=1e-9)
        u = docs[law]["uncertainty"]["mu0"]
        assert u["ci95"][0] <= min(u["ci95_hac"][0], check["params"]["mu0"]), u
        assert u["ci95"][1] >= max(u["ci95_hac"][1], check["params"]["mu0"]), u
        assert u["ci95"][0] <= mu0 <= u["ci95"][1], (law, u)
    own = docs["normal"]["uncertainty"]["mu0"]  # the normal law's sandwich alone misses it
    assert abs(docs["normal"]["params"]["mu0"] - mu0) > Z95 * own["stderr_hac"], own
    single = json.loads(jadhesion("fit", rec, "--method", "lm", "--json", "--single-law").stdout)
    assert "slip_law_check" not in single and single["params"] == docs["normal"]["params"]
    assert single["uncertainty"]["mu0"]["ci95"] == docs["normal"]["uncertainty"]["mu0"]["ci95_hac"]
    raw = jadhesion("fit", rec, "--method", "lm", "--json", "--creep", "raw", "--slip-law", "population")
    assert json.loads(raw.stdout)["slip_law"] is None and "slip_law_check" not in json.loads(raw.stdout)
    assert "--slip-law population has no effect" in raw.stderr


def test_text_tables_show_no_python_none():
    """A missing value (a p-value where no null ran) is a dash in the text tables, not 'None';
    floats in 4 significant digits, an absent key an empty cell."""
    text = table([{"a": None, "b": 0.123456}, {"a": 2}], ["a", "b"])
    assert "None" not in text and text.splitlines()[2].split() == ["-", "0.1235"]
    assert text.splitlines()[3].split() == ["2"]
