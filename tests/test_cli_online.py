"""``jadhesion online FILE``: contract, shared code path with ``reproduce online``, a_s estimate,
standstill/coasting guards, bad input."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.cli import main
from jadhesion.cli.online import ALGORITHM_NAMES, FORGETTING
from jadhesion.data.dataset import PolachDataset
from jadhesion.data.recording import save_recording
from jadhesion.data.simulator import simulate
from jadhesion.experiments import online as ex
from jadhesion.identify import online as ol
from jadhesion.identify.kiencke_fit import fit_kiencke, informative
from jadhesion.models.kiencke import kiencke_adhesion
from jadhesion.status import Status
from validation.foreign_generator import generate, write

TRUE = (80.0, 100.0, 35.0)  # p1, p2, a_s
KEYS = {"algorithm", "a_s", "final", "track", "status"}


def _run(capsys, *argv):
    code = main([*map(str, argv), "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


@pytest.fixture(scope="module")
def sweep_csv(tmp_path_factory):
    """The reproduce-online creep sweep as a fitting dataset (200 steps, one rail), with 30 standstill
    and 30 coasting samples spliced in."""
    sc = ex.scenario(jax.random.key(7), n_steps=200, changes=(), rails=("normal",), noise=0.001)
    lam, mu = np.array(sc.lam), np.array(sc.mu)
    v = np.full(200, 1.5)
    v[50:80] = 0.0  # standstill: creep undefined
    mu[120:150] = 0.0  # coasting: no information
    path = tmp_path_factory.mktemp("sweep") / "sweep.csv"
    save_recording({"creepage": lam, "vehicle_speed": v, "adhesion": mu}, path=path)
    return path, lam, mu, v


def test_shares_the_reproduce_code_path_exactly(capsys, sweep_csv):
    path, lam, mu, v = sweep_csv
    code, doc, _ = _run(capsys, "online", path, "--algorithm", "2", "--a-s", 35)
    assert code == 0 and KEYS <= set(doc) and doc["status"] == "converged"
    used = (v >= 0.1) & (np.abs(mu) >= 0.02)
    state, trace = ol.run(ol.algorithm2_params(), jnp.asarray(lam), jnp.asarray(mu), jnp.asarray(used))
    np.testing.assert_allclose(doc["track"]["p1"], trace.p1, rtol=1e-12)
    np.testing.assert_allclose(doc["track"]["eta"], trace.eta, rtol=1e-12)
    assert doc["track"]["used"] == used.tolist() and doc["n_used"] == 140
    # a skipped sample holds the estimate and reports η = 1
    assert doc["track"]["p2"][60] == doc["track"]["p2"][49] and doc["track"]["eta"][60] == 1.0


def test_tracking_runs_padded_to_its_bucket_and_returns_its_own_samples(sweep_csv):
    """``track_dataset`` runs the offline a_s fit and the tracker on the dataset padded to its
    length bucket (200 → 256 rows: one program per bucket), with a mask of its own and times with a
    gap: the trace is its 200 samples', bit for bit the unpadded tracker's, and a_s the unpadded
    fit's to round-off."""
    _, lam, mu, v = sweep_csv
    weight = np.ones(200)
    weight[160:170] = 0.0  # another phase's samples: held
    time = np.r_[np.arange(100) * 0.02, 10.0 + np.arange(100) * 0.02]
    data = PolachDataset(*map(jnp.asarray, (lam, lam * v, mu, v, 1.0)), weight=jnp.asarray(weight))
    programs = ol.run._cache_size()
    shorter = jax.tree.map(lambda a: a[:190] if jnp.ndim(a) else a, data)
    ol.track_dataset(shorter, "1", None, jax.random.key(0), time[:190])
    out = ol.track_dataset(data, "1", None, jax.random.key(0), time)
    assert ol.run._cache_size() <= programs + 1  # 190 and 200 rows: one tracker program
    fit = fit_kiencke(data, "lm", jax.random.key(0))
    assert int(out.slope_fit.status) == int(fit.status) == Status.CONVERGED
    assert float(out.a_s) == pytest.approx(float(fit.params[2]), rel=1e-9)
    used = informative(data) > 0
    ratio = jnp.asarray(ol.step_ratios(time))
    state, trace = ol.run(ol.algorithm1_params(a_s=out.a_s), data.creep, data.adhesion, used, ratio)
    assert out.used.shape == (200,) and out.used.tolist() == np.asarray(used).tolist()
    for name, got, want in zip(trace._fields, out.trace, trace, strict=True):
        assert got.shape[0] == 200 and np.array_equal(got, np.asarray(want)), name
    assert int(out.status) == int(ol.final_status(state))


@pytest.mark.parametrize("alg", ["1", "2", "rls"])
def test_estimates_a_s_and_tracks_the_optimum(capsys, sweep_csv, alg):
    code, doc, _ = _run(capsys, "online", sweep_csv[0], "--algorithm", alg)
    assert code == 0 and doc["a_s_source"] == "estimated" and doc["algorithm"] == alg
    # σ = 0.001 on these 140 samples: Gauss–Newton standard errors a_s 0.47 %, p2 0.37 %
    # (λ_m = 1/√p2: 0.19 %); tolerances 4 standard errors, μ_m (a ratio of both) 1 %
    assert doc["a_s"] == pytest.approx(TRUE[2], rel=0.02)
    assert doc["final"]["creep_opt"] == pytest.approx(0.1, rel=0.008)
    assert doc["final"]["mu_max"] == pytest.approx(0.35, rel=0.01)
    for field in ("time", "p1", "p2", "mu_max", "creep_opt", "eta"):
        assert len(doc["track"][field]) == 200 and None not in doc["track"][field][80:]


def test_raw_recording_with_standstill_never_nan(capsys, tmp_path):
    sim = simulate("wet", seed=1, n_samples=300)
    cols = {k: np.array(sim.columns[k]) for k in ("time", "vehicle_speed", "wheel_speed", "traction_torque")}
    cols["vehicle_speed"][:40] = cols["wheel_speed"][:40] = 0.0  # a standstill start
    path = save_recording(cols, sim.vehicle, tmp_path / "raw.csv")
    code, doc, _ = _run(capsys, "online", path, "--plot", tmp_path / "fig")
    assert code == 0 and doc["n_used"] <= 260 and not any(doc["track"]["used"][:40])
    finite = np.array([x for f in ("p1", "p2", "eta") for x in doc["track"][f]], dtype=float)
    assert np.all(np.isfinite(finite))
    assert (tmp_path / "fig" / "raw_online.png").stat().st_size > 20_000


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--a-s", "-3"], "--a-s"),
        (["--a-s", "nan"], "--a-s"),
        (["--a-s", "1e308"], "--a-s"),
        (["--seed", "99999999999999999999999"], "--seed"),
        (["--algorithm", "3"], None),
    ],
)
def test_bad_options_exit_2_and_write_nothing(capsys, sweep_csv, tmp_path, argv, needle):
    try:
        code = main(["online", str(sweep_csv[0]), *argv, "--plot", str(tmp_path / "p")])
    except SystemExit as exc:  # argparse's choices
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "p").exists()
    if needle:
        assert needle in err and len(err.strip().splitlines()) == 1


def test_no_informative_sample_is_a_clear_error(capsys, tmp_path):
    still = {"creepage": np.full(50, 0.01), "vehicle_speed": np.zeros(50), "adhesion": np.full(50, 0.3)}
    code, _, err = _run(capsys, "online", save_recording(still, path=tmp_path / "still.csv"))
    assert code == 2 and "selects no samples (standstill 50)" in err
    still["vehicle_speed"][-5:] = 1.5  # five moving samples: selected, too few to track
    code, _, err = _run(capsys, "online", save_recording(still, path=tmp_path / "five.csv"))
    assert code == 2 and "only 5 informative samples" in err


@pytest.fixture(scope="module")
def raw_recording(tmp_path_factory):
    sim = simulate("dry", seed=3, n_samples=600)
    cols = {k: np.array(sim.columns[k]) for k in ("time", "vehicle_speed", "wheel_speed", "traction_torque")}
    return cols, sim.vehicle, tmp_path_factory.mktemp("online_raw")


def test_takes_the_recording_options_of_the_other_commands(capsys, raw_recording):
    """DESIGN §3: every command that reads a recording takes --column (and --start/--end, --phase):
    a logger's names and units give the track of the canonical file, and a window tracks only its
    samples."""
    cols, vehicle, tmp = raw_recording
    _, plain, _ = _run(capsys, "online", save_recording(cols, vehicle, tmp / "plain.csv"))
    logger = {"t_ms": cols["time"] * 1e3, "v_kmh": cols["vehicle_speed"] * 3.6}
    logger |= {"vw": cols["wheel_speed"], "M_kNm": cols["traction_torque"] / 1e3}
    path = save_recording(logger, vehicle, tmp / "logger.csv")
    maps = ["time=t_ms[ms]", "vehicle_speed=v_kmh[km/h]", "wheel_speed=vw", "traction_torque=M_kNm[kN*m]"]
    code, doc, err = _run(capsys, "online", path, *[a for m in maps for a in ("--column", m)])
    assert code == 0, err
    np.testing.assert_allclose(doc["final"]["p2"], plain["final"]["p2"], rtol=1e-6)
    t_mid = float(cols["time"][300])
    code, doc, err = _run(capsys, "online", tmp / "plain.csv", "--start", t_mid)
    assert code == 0 and doc["n_samples"] == 300 and doc["track"]["time"][0] >= t_mid


def test_running_backwards_is_tracked_as_traction(capsys, raw_recording):
    """Speeds and torque negated (the same test run in the other direction): creep and μ̂ are
    oriented by the direction of travel, so the track is the same one."""
    cols, vehicle, tmp = raw_recording
    _, plain, _ = _run(capsys, "online", save_recording(cols, vehicle, tmp / "plain.csv"))
    back = {k: (v if k == "time" else -v) for k, v in cols.items()}
    code, doc, err = _run(capsys, "online", save_recording(back, vehicle, tmp / "back.csv"))
    assert code == 0, err
    assert doc["n_used"] == plain["n_used"] > 500
    for field in ("p1", "p2", "mu_max"):
        np.testing.assert_allclose(doc["final"][field], plain["final"][field], rtol=1e-8)


def test_argument_choices_match_the_algorithm_registry():
    assert ALGORITHM_NAMES == tuple(ol.ALGORITHMS)
    assert FORGETTING == ol.FORGETTING


def _settle_s(doc, truth, after):
    """Seconds after ``after`` from which the tracked mu_max stays within 1 % of ``truth``."""
    t, mu_max = np.asarray(doc["track"]["time"]), np.asarray(doc["track"]["mu_max"], float)
    off = np.flatnonzero((t >= after) & (np.abs(mu_max / truth - 1.0) > 0.01))
    return t[off[-1] + 1] - after


def test_forgetting_is_counted_in_seconds_so_the_logging_rate_keeps_the_memory(capsys, tmp_path):
    """The same run (creep sweeping both sides of the optimum every 2 s, a rail change μ_max
    0.36 → 0.30 at 10 s, noise-free) logged at 50 and 200 Hz: forgetting per second (the default)
    settles on the new rail after the same time at both rates (RLS, η = 0.98 at 50 Hz: within one
    50 Hz step); the paper's per-sample η forgets 4× faster in seconds at 200 Hz. At 50 Hz both
    are the same run."""
    a_s, p2 = 540.0, 156.0
    docs = {}
    for rate in (50, 200):
        t = np.arange(20 * rate) / rate
        lam = 0.05 + 0.04 * np.sin(np.pi * t)
        p1 = np.where(t < 10.0, a_s / 0.36, a_s / 0.30) - 2.0 * np.sqrt(p2)
        mu = np.asarray(kiencke_adhesion(lam, p1, p2, a_s))
        path = tmp_path / f"rail_{rate}.csv"
        save_recording(
            {"time": t, "creepage": lam, "vehicle_speed": np.full(t.size, 2.0), "adhesion": mu}, path=path
        )
        for forgetting in FORGETTING:
            argv = ("online", path, "--algorithm", "rls", "--a-s", a_s, "--forgetting", forgetting)
            code, docs[rate, forgetting], _ = _run(capsys, *argv)
            assert code == 0 and docs[rate, forgetting]["forgetting"]["per"] == forgetting[:-1] + "s"
    settle = {k: _settle_s(doc, 0.30, 10.0) for k, doc in docs.items()}
    assert settle[50, "seconds"] > 0.5 and abs(settle[200, "seconds"] - settle[50, "seconds"]) <= 0.02
    assert settle[200, "samples"] < 0.4 * settle[50, "samples"]
    np.testing.assert_allclose(
        docs[50, "seconds"]["track"]["p1"], docs[50, "samples"]["track"]["p1"], rtol=1e-9
    )
    # the applied forgetting per 200 Hz step is η^(1/4)
    eta = np.asarray(docs[200, "seconds"]["track"]["eta"])
    np.testing.assert_allclose(eta[100:500], 0.98**0.25, rtol=1e-12)


def test_step_ratios_hold_across_gaps():
    """Δt / 20 ms per row; the first row and a step across a gap take the median step."""
    t = np.r_[np.arange(10) * 0.005, 30.0 + np.arange(5) * 0.005]
    ratio = ol.step_ratios(t)
    np.testing.assert_allclose(ratio, 0.25, rtol=1e-9)
    assert ol.step_ratios(np.array([3.0])).tolist() == [1.0]


def test_a_stuck_snr_step_is_warned_and_the_guarded_step_tracks_the_change(capsys, tmp_path):
    """Algorithm 1's SNR step after a macro-slip excursion (creep to 0.8 over 1 s): with η held at
    η_max = 1, H stops changing, the SNR matrix stays inside its interval and the estimate stops
    following the data, so a later rail change (μ_max 0.36 → 0.30) goes untracked. The command
    says so (``snr_hold`` from the excursion to the end). Algorithm 1-guarded (the hold ends when
    the error leaves 3 noise sd) and Algorithm 2 (no SNR step) track the change to within 0.01
    (noise 0.004) without that warning."""
    a_s, p2 = 540.0, 156.0
    rng = np.random.default_rng(0)
    n = 2000
    lam = 0.005 + 0.002 * np.sin(np.arange(n) / 15.0) + 0.001 * rng.normal(size=n)
    lam[600:650] = 0.005 + 0.8 * np.sin(np.linspace(0.0, np.pi, 50))
    p1 = np.where(np.arange(n) < 1300, a_s / 0.36, a_s / 0.30) - 2.0 * np.sqrt(p2)
    mu = np.asarray(kiencke_adhesion(lam, p1, p2, a_s)) + 0.004 * rng.normal(size=n)
    path = tmp_path / "excursion.csv"
    columns = {"time": np.arange(n) * 0.02, "creepage": lam, "vehicle_speed": np.full(n, 2.0), "adhesion": mu}
    save_recording(columns, path=path)
    _, one, _ = _run(capsys, "online", path, "--algorithm", "1", "--a-s", a_s)
    for alg in ("1-guarded", "2"):
        _, other, _ = _run(capsys, "online", path, "--algorithm", alg, "--a-s", a_s)
        assert "snr_hold" not in {w["code"] for w in other["warnings"]}
        assert other["final"]["mu_max"] == pytest.approx(0.30, abs=0.01)
    [hold] = [w for w in one["warnings"] if w["code"] == "snr_hold"]
    assert hold["code"] == "snr_hold" and hold["to_end"] and 12.0 <= hold["from_s"] <= 13.5
    assert one["final"]["mu_max"] == pytest.approx(0.36, abs=0.01)  # the change at 26 s unseen


def test_a_run_that_ends_without_an_optimum_says_so(capsys, tmp_path):
    """The independent generator's steady run (seed 1, mild sensors) ends in 30 s of low adhesion
    (≈ 0.04) at creep ≈ 10⁻³, far below any optimum: Algorithm 1 with the paper's per-sample
    forgetting forgets the earlier peak and ends with p2 ≤ 0, a curve without a peak. The command
    says so (``no_optimum``, creep_opt none) exactly when the final p2 is not positive, for every
    identifier."""
    path = write(generate(1, effect="none", sensor="mild"), tmp_path / "steady.csv")
    for alg in ALGORITHM_NAMES:
        code, doc, _ = _run(capsys, "online", path, "--algorithm", alg)
        warned = [w for w in doc["warnings"] if w["code"] == "no_optimum"]
        assert code == 0 and bool(warned) == (doc["final"]["p2"] <= 0), alg
        if warned:
            assert doc["final"]["creep_opt"] is None
    _, one, _ = _run(capsys, "online", path, "--algorithm", "1", "--forgetting", "samples")
    assert one["final"]["p2"] <= 0 and one["final"]["creep_opt"] is None
    assert "no_optimum" in {w["code"] for w in one["warnings"]}


def test_a_peak_below_the_data_is_named(capsys, tmp_path):
    """The independent generator's steady run (seed 3, 25 Hz, mild sensors) ends with Algorithm 1's
    mu_max at 0.07 against a true peak of 0.31, below most of the adhesion the run itself shows:
    ``peak_below_data``. Its start (seed 3, 50 Hz), tracked to within 1 % of the true 0.316, is
    not warned. Its sweep (seed 2, realistic sensors) shows μ̂ up to 0.43 and then ends 30 s low on
    the curve (median |μ̂| 0.04) with mu_max 0.077: below the adhesion the run showed, which the
    median |μ̂| as the level did not see; the warning says when the run last showed it."""
    steady = write(generate(3, effect="none", sensor="mild", rate_hz=25.0), tmp_path / "steady.csv")
    start = generate(3, effect="none", sensor="mild", rate_hz=50.0, profile="start", duration_s=30.0)
    start = write(start, tmp_path / "start.csv")
    _, doc, _ = _run(capsys, "online", steady, "--algorithm", "1")
    assert doc["final"]["mu_max"] < 0.2 and "peak_below_data" in {w["code"] for w in doc["warnings"]}
    _, doc, _ = _run(capsys, "online", start, "--algorithm", "1")
    assert doc["final"]["mu_max"] == pytest.approx(0.316, rel=0.02)
    assert "peak_below_data" not in {w["code"] for w in doc["warnings"]}
    sweep = write(
        generate(2, effect="none", sensor="realistic", rate_hz=50.0, profile="sweep"), tmp_path / "sw.csv"
    )
    _, doc, _ = _run(capsys, "online", sweep, "--algorithm", "1")
    (below,) = [w for w in doc["warnings"] if w["code"] == "peak_below_data"]
    assert doc["final"]["mu_max"] < 0.5 * 0.417 and below["level"] > 0.35
    assert below["last_at_s"] < doc["track"]["time"][-1] - 20.0  # before the low end
    assert f"last at {below['last_at_s']:.1f} s" in below["message"]
    # on a clock of seconds since the epoch, the time is said from the first sample, as diagnose does
    text = sweep.read_text().splitlines()
    rows = [line.split(",") for line in text[1:]]
    shifted = "\n".join([text[0], *(",".join([repr(float(r[0]) + 1.7e9), *r[1:]]) for r in rows)])
    epoch = tmp_path / "sw_epoch.csv"
    epoch.write_text(shifted + "\n")
    epoch.with_suffix(".json").write_text(sweep.with_suffix(".json").read_text())
    _, doc, _ = _run(capsys, "online", epoch, "--algorithm", "1")
    (late,) = [w for w in doc["warnings"] if w["code"] == "peak_below_data"]
    assert f"last at {below['last_at_s']:.1f} s after the first fitted sample" in late["message"]


def test_a_run_without_excitation_says_so_and_an_extrapolated_peak_is_named(capsys, sweep_csv, tmp_path):
    """Constant creep (0.003, the curve's rising branch; fuzzing found Algorithm 2 printing a
    creep_opt of 0.05 with status singular and no warning): a ``not_converged`` warning for the
    singular status and ``peak_extrapolated`` for a tracked optimum beyond the data's creep. The
    reproduce sweep, which crosses the peak, gets neither."""
    rng = np.random.default_rng(3)
    lam = 0.003 + 1e-5 * rng.standard_normal(400)
    mu = np.asarray(kiencke_adhesion(lam, *TRUE)) + 0.002 * rng.standard_normal(400)
    path = tmp_path / "flat.csv"
    save_recording({"creepage": lam, "vehicle_speed": np.full(400, 10.0), "adhesion": mu}, path=path)
    code, doc, _ = _run(capsys, "online", path, "--algorithm", "2")
    codes = {w["code"] for w in doc["warnings"]}
    assert code == 0 and doc["status"] == "singular" and "not_converged" in codes
    if doc["final"]["creep_opt"] is not None and doc["final"]["creep_opt"] > lam.max():
        assert "peak_extrapolated" in codes
    assert doc["final"]["creep_opt"] is None or "peak_extrapolated" in codes  # no peak inside 0.003 ± 3e-5
    code, doc, _ = _run(capsys, "online", sweep_csv[0], "--algorithm", "2")
    assert code == 0 and not {"not_converged", "peak_extrapolated"} & {w["code"] for w in doc["warnings"]}


def test_a_short_stretch_and_an_inverted_torque_are_warned_as_fit_warns_them(capsys, tmp_path):
    """A start (30 s, 50 Hz) tracked over its last 0.5 s only: ``few_samples`` (fit says the same;
    11 samples once ended at mu_max 1.93, 'converged', with no such warning), which the whole run
    does not get. The same run with the torque's sign inverted, tracked with --phase both:
    ``creep_sign``, as fit and posterior say it."""
    rec = generate(0, effect="none", sensor="realistic", rate_hz=50.0, profile="start", duration_s=30.0)
    path = write(rec, tmp_path / "start.csv")
    _, whole, _ = _run(capsys, "online", path)
    _, short, _ = _run(capsys, "online", path, "--start", "29.5")
    codes = lambda doc: {w["code"] for w in doc["warnings"]}  # noqa: E731
    assert "few_samples" not in codes(whole) and "few_samples" in codes(short)
    assert short["n_used"] < 100 <= whole["n_used"]
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    flipped = tmp_path / "flipped.csv"
    flipped.write_text("\n".join([lines[0], *(",".join([*r[:3], repr(-float(r[3]))]) for r in rows)]) + "\n")
    flipped.with_suffix(".json").write_text(path.with_suffix(".json").read_text())
    _, doc, _ = _run(capsys, "online", flipped, "--phase", "both")
    assert "creep_sign" in codes(doc) and "creep_sign" not in codes(whole)
