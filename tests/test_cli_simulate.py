"""``jadhesion simulate`` for researchers: own parameters, duration, rate, vehicle, braking tests."""

import json

import numpy as np
import pytest

from jadhesion.cli import main, simulate
from jadhesion.data.dataset import to_dataset
from jadhesion.data.recording import load_recording
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.data.simulator import DEFAULT_SAMPLES, SAMPLE_PERIOD
from jadhesion.models.effects import EFFECT_NAMES
from jadhesion.models.polach import PARAM_NAMES, polach_adhesion


def _simulate(capsys, out, *argv):
    code = main(["simulate", *map(str, argv), "--out", str(out), "--json"])
    captured = capsys.readouterr()
    return code, (json.loads(captured.out) if code == 0 else None), captured.err


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Traction and braking, same seed, own parameters, 10 s at 100 Hz, a lighter locomotive."""
    d = tmp_path_factory.mktemp("sim")
    (d / "loco.json").write_text(json.dumps({"axle_load_kg": 20000.0, "name": "light"}))
    out = {}
    for test in ("traction", "braking"):
        argv = [
            "simulate",
            "--scenario",
            "wet",
            "--params",
            "kA=0.3,mu0=0.3",
            "--duration",
            "10",
            "--rate",
            "100",
            "--vehicle",
            d / "loco.json",
            "--test",
            test,
            "--seed",
            "4",
            "--out",
            d / f"{test}.csv",
            "--json",
        ]
        assert main(list(map(str, argv))) == 0
        out[test] = d / f"{test}.csv"
    return out


def test_truth_records_everything(pair, capsys):
    capsys.readouterr()
    truth = json.loads(pair["braking"].with_suffix(".truth.json").read_text())
    assert truth["params"] == {"kA": 0.3, "kS": 1.0, "mu0": 0.3, "A": 0.6858, "B": 0.2251}
    assert truth["rate_hz"] == 100.0 and truth["duration_s"] == pytest.approx(10.0)
    assert truth["test"] == "braking" and truth["seed"] == 4 and truth["scenario"] == "wet"
    assert truth["vehicle"]["axle_load_kg"] == 20000.0 and truth["vehicle"]["name"] == "light"
    assert {"noise", "effects", "envelope", "sample_period_s"} <= set(truth)
    rec = load_recording(pair["braking"])
    assert rec.n_samples == 1001 and rec.vehicle.axle_load_kg == 20000.0
    np.testing.assert_allclose(np.diff(rec.columns["time"]), 0.01, rtol=1e-9)


def test_given_parameters_generate_the_data(pair):
    """The observed mu_hat (smoothed creep, realistic sensors) follows the given parameters to the
    noise floor, not the scenario's."""
    for path in pair.values():
        data = to_dataset(load_recording(path))
        truth = json.loads(path.with_suffix(".truth.json").read_text())
        mae = {}
        for label, theta in (
            ("given", [truth["params"][k] for k in PARAM_NAMES]),
            ("scenario", [1.0, 1.0, 0.2610, 0.6858, 0.2251]),
        ):
            model = polach_adhesion(np.asarray(theta), data.creep, data.slip, truth["k_eps"])
            mae[label] = float(np.mean(np.abs(np.asarray(model) - np.asarray(data.adhesion))))
        # realistic sensors: the true parameters' floor on smoothed creep is ~0.018 (wet scenario)
        assert mae["given"] < 0.025 and mae["scenario"] > 1.5 * mae["given"], mae


def test_coast_adds_a_coasting_gap(capsys, tmp_path):
    """``--coast 2``: the summary and the truth give the gap's flat part, 2 s long, at a quarter or
    three quarters of the run; μ̂ there is noise about 0, elsewhere the wet run's adhesion."""
    code, summary, _ = _simulate(
        capsys, tmp_path / "c.csv", "--scenario", "wet", "--duration", "10", "--rate", "100", "--coast", "2"
    )
    assert code == 0
    gap = summary["coasting"]
    assert gap == json.loads((tmp_path / "c.truth.json").read_text())["coasting"]
    assert gap["end_s"] - gap["start_s"] == pytest.approx(2.0)
    assert 0.5 * (gap["start_s"] + gap["end_s"]) in (pytest.approx(2.5), pytest.approx(7.5))
    cols = load_recording(tmp_path / "c.csv").columns
    inside = (cols["time"] >= gap["start_s"]) & (cols["time"] <= gap["end_s"])
    assert abs(np.mean(cols["adhesion"][inside])) < 0.01 < 0.1 < np.mean(cols["adhesion"][~inside])
    argv = ["simulate", "--scenario", "wet", "--duration", "10", "--rate", "100", "--coast", "2"]
    assert main([*argv, "--out", str(tmp_path / "d.csv")]) == 0
    assert f"coasting gap {gap['start_s']:.2f}–{gap['end_s']:.2f} s" in capsys.readouterr().out


def test_braking_mirrors_traction(pair):
    t, b = (load_recording(pair[k]).columns for k in ("traction", "braking"))
    assert np.all(t["traction_torque"] > 0) and np.all(b["traction_torque"] < 0)
    # recorded (raw) creep: realistic speed noise flips the sign of the smallest values only
    assert np.mean(t["creepage"][100:] > 0) > 0.95 and np.mean(b["creepage"][100:] < 0) > 0.95
    assert np.all(b["vehicle_speed"] > 0)  # still running forwards
    # odd model, same profile and noise seed: |mu_hat| agrees up to the (even) running resistance
    np.testing.assert_allclose(np.mean(-b["adhesion"]), np.mean(t["adhesion"]), rtol=0.02)


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["--params", "kA=2"], "--params"),
        (["--params", "kA"], "--params"),
        (["--params", "mu0=x"], "--params"),
        (["--params", "foo=1"], "--params"),
        (["--duration", "-1"], "--duration"),
        (["--duration", "1"], "--duration"),
        (["--rate", "0"], "--rate"),
        (["--rate", "nan"], "--rate"),
        (["--vehicle", "missing.json"], "--vehicle"),
        (["--vehicle", "BAD"], "--vehicle"),
        (["--sensor-noise", "11"], "--sensor-noise"),  # above 10× realistic: 1e9 wrote -1e6 m/s
        (["--sensor-noise", "nan"], "--sensor-noise"),
        (["--seed", "-1"], "--seed"),
        (["--coast", "19"], "--coast"),  # 39.98 s: at most 18.99 s (half, less the edges)
        (["--coast", "-1"], "--coast"),
        (["--coast", "nan"], "--coast"),
    ],
)
def test_bad_values_exit_2_naming_the_flag(capsys, tmp_path, argv, flag):
    (tmp_path / "BAD.json").write_text('{"axle_load_kg": -1}')
    argv = [a.replace("BAD", str(tmp_path / "BAD.json")) for a in argv]
    code, _, err = _simulate(capsys, tmp_path / "x.csv", *argv)
    assert code == 2 and err.count("\n") == 1 and flag in err
    assert list(tmp_path.iterdir()) == [tmp_path / "BAD.json"]  # nothing written


@pytest.mark.parametrize(
    "vehicle", [{"wheel_radius_m": 1e-300}, {"wheel_radius_m": 1e300}, {"wheelset_inertia_kgm2": 1e300}]
)
def test_a_vehicle_whose_recording_fit_would_refuse_writes_nothing(capsys, tmp_path, vehicle):
    """A sidecar vehicle far outside any locomotive: one line naming ``--vehicle`` and what a
    reader would refuse, nothing written (a radius of 1e-300 wrote an inf adhesion column and its
    sidecar, then ended in a NaN-truth traceback; 1e300 and the inertia wrote a file fit refuses)."""
    (tmp_path / "v.json").write_text(json.dumps(vehicle))
    code, _, err = _simulate(capsys, tmp_path / "x.csv", "--vehicle", tmp_path / "v.json", "--duration", "2")
    assert code == 2 and err.count("\n") == 1 and "--vehicle" in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == [tmp_path / "v.json"]


def test_out_onto_a_directory_is_refused_before_simulating(capsys, tmp_path):
    """A directory where the recording (or its sidecar) would go: one line at once, not
    '[Errno 21] Is a directory' after the simulation."""
    (tmp_path / "d.csv").mkdir()
    (tmp_path / "r.json").mkdir()
    code, _, err = _simulate(capsys, tmp_path / "d.csv")
    assert code == 2 and err == f"jadhesion: error: --out {tmp_path / 'd.csv'}: is a directory\n"
    code, _, err = _simulate(capsys, tmp_path / "r.csv")
    assert code == 2 and err.count("\n") == 1 and "r.json (written beside it) is a directory" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.csv", "r.json"]


def test_help_names_and_defaults_are_the_catalogues_and_the_simulators():
    """The JAX-free argument module's copies (help text only) equal what they copy."""
    assert simulate.SCENARIO_NAMES == tuple(SCENARIOS)
    assert simulate.EFFECT_NAMES == EFFECT_NAMES
    assert simulate.DEFAULT_RATE_HZ == 1.0 / SAMPLE_PERIOD
    assert simulate.DEFAULT_DURATION_S == pytest.approx((DEFAULT_SAMPLES - 1) * SAMPLE_PERIOD, rel=1e-12)


def test_summary_duration_is_rounded(capsys, tmp_path):
    """The default run's 1 999 steps of 0.02 s: 39.98 s in the summary, not 39.980000000000004."""
    code, summary, _ = _simulate(capsys, tmp_path / "r.csv")
    assert code == 0 and json.dumps(summary["duration_s"]) == "39.98"
