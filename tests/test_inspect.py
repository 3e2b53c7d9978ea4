"""``jadhesion inspect``: sampling, gaps, ranges, selection and identifiability of a logger file."""

import json

import numpy as np
import pytest
from logger_data import stretches_si, swapped_stretches, write_logger_file

from jadhesion.cli import main
from jadhesion.cli.inspect_run import _excluded_line, _grouped
from jadhesion.data.inspection import MU_IMPLAUSIBLE, identifiability, implausible_adhesion, sampling
from jadhesion.data.recording import save_recording
from jadhesion.data.vehicle import LOCO_22E
from validation.foreign_generator import generate, write


@pytest.fixture(scope="module")
def logger_file(tmp_path_factory):
    return write_logger_file(tmp_path_factory.mktemp("inspect") / "log.csv")


def test_inspect_json_values(logger_file, capsys, tmp_path):
    assert main(["inspect", str(logger_file), "--json", "--plot", str(tmp_path / "plots")]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["samples"] == 1200 and doc["sources"]["vehicle_speed"] == "v_Lok_kmh[km/h]"
    s = doc["sampling"]
    assert s["duration_s"] == pytest.approx(13.99) and s["rate_hz"] == pytest.approx(100.0)
    assert s["step_s"]["max"] == pytest.approx(2.01) and s["jitter"] < 1e-9
    assert s["gaps"] == [[pytest.approx(8.99), pytest.approx(11.0)]]
    r = doc["ranges"]  # over the 700 traction samples: speed 2..2.1 and 3..3.15 m/s, creep 1-2 %
    assert r["vehicle_speed"] == pytest.approx([2.0, 3.15], abs=1e-3)
    assert r["creep"] == pytest.approx([0.01, 0.02], abs=5e-4)
    assert r["slip_velocity"][1] == pytest.approx(0.063, abs=1e-3)
    sel = doc["selection"]
    assert sel["used"] == 700 and [e["reason"] for e in sel["excluded"]] == [
        "standstill",
        "coasting",
        "braking",
    ]
    codes = [n["code"] for n in doc["identifiability"]]
    assert codes == ["slip_range", "no_small_creep"]
    assert "slip velocity never exceeds 0.5 m/s" in doc["identifiability"][0]["message"]
    assert (tmp_path / "plots" / "inspect.png").stat().st_size > 20_000
    assert doc["plots"] == [str(tmp_path / "plots" / "inspect.png")]  # what it wrote, as online says


def test_inspect_text_and_braking(logger_file, capsys):
    assert main(["inspect", str(logger_file), "--phase", "braking"]) == 0
    out = capsys.readouterr().out
    assert "selected: 300 of 1200 samples (braking); 2 stretches between gaps" in out
    assert "excluded traction: 11–13.99 s, 300 samples" in out
    assert "gap 8.99 s → 11 s" in out


def test_identifiability_rules():
    s = np.geomspace(1e-3, 0.3, 400)
    rising = identifiability(s, s * 3.0, 0.4 * s / (0.01 + s))  # w up to 0.9 m/s, no peak
    assert [n["code"] for n in rising] == ["no_peak"]
    peaked = identifiability(s, s * 3.0, 0.4 * s / (0.01 + s) * np.exp(-3 * s))
    assert peaked == []
    few = identifiability(s[:50] + 0.01, s[:50], s[:50])
    assert [n["code"] for n in few] == ["few_samples", "slip_range", "no_peak", "no_small_creep"]
    # the same curve seen at one speed (3 m/s ± 1 %, a rig's) and over a start's speeds
    mu, rng = 0.4 * s / (0.01 + s) * np.exp(-3 * s), np.random.default_rng(0)
    rig = identifiability(s, s * 3.0, mu, rng.uniform(2.97, 3.03, s.size))
    assert [n["code"] for n in rig] == ["single_speed"] and "2.97" in rig[0]["message"]
    assert identifiability(s, s * 3.0, mu, rng.uniform(1.0, 3.0, s.size)) == []


def test_sampling_jitter():
    t = np.arange(1000) * 0.01 + np.random.default_rng(0).uniform(-1e-3, 1e-3, 1000)
    doc = sampling(t)
    assert doc["rate_hz"] == pytest.approx(100.0, rel=1e-2)
    assert doc["jitter"] == pytest.approx(np.sqrt(2 / 3) * 0.1, rel=0.1)  # two uniforms of ±1e-3


def test_inspect_bad_plot_dir(logger_file, tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    assert main(["inspect", str(logger_file), "--plot", str(tmp_path / "f")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--plot" in err


def test_implausible_adhesion_is_named_at_the_95th_percentile():
    """μ̂ of a wheel–rail contact stays below 0.6: a recording whose μ̂ is mostly above
    :data:`MU_IMPLAUSIBLE` is mis-scaled (torque unit or place, axle load, radius) and says so; a
    few noisy samples above it do not."""
    mu = np.full(1000, 0.35)
    assert implausible_adhesion(mu) is None
    mu[:40] = 1.5  # 4 % of the samples: observer noise spikes, not a scale error
    assert implausible_adhesion(mu) is None
    note = implausible_adhesion(-2.5 * np.full(1000, 0.4))  # braking counts by magnitude
    assert note["code"] == "implausible_adhesion" and "axle_load_kg" in note["message"]
    s = np.linspace(0.001, 0.3, 1000)
    codes = [n["code"] for n in identifiability(s, s * 3.0, (MU_IMPLAUSIBLE + 0.4) * s / (0.01 + s))]
    assert "implausible_adhesion" in codes


def test_inspect_text_of_a_selection_without_samples(logger_file, capsys):
    """Braking asked of the first 5 s (standstill and traction): the text says so instead of failing (the JSON
    gives ``null`` ranges)."""
    assert main(["inspect", str(logger_file), "--phase", "braking", "--end", "4.9"]) == 0
    out = capsys.readouterr().out
    assert "selected: 0 of" in out and "creep: no selected samples" in out
    assert "stretch" not in out  # one stretch, no gap: nothing to count (it said "1 stretch(es)")
    assert "identifiability [few_samples]: no sample selected: nothing to identify" in out
    assert main(["inspect", str(logger_file), "--phase", "braking", "--end", "4.9", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ranges"]["creep"] is None


def test_inspect_says_when_the_speed_columns_look_swapped(tmp_path, capsys):
    """Wheel and vehicle speed exchanged on both traction stretches: 700 of the 1100 moving samples
    have the wheel slower than the vehicle under traction; inspect names the likely cause first."""
    cols = swapped_stretches()
    path = save_recording(cols, LOCO_22E, tmp_path / "swapped.csv")
    assert main(["inspect", str(path), "--phase", "braking", "--json"]) == 0
    first = json.loads(capsys.readouterr().out)["identifiability"][0]
    assert first["code"] == "creep_sign"
    assert first["message"].startswith("wheel slower than vehicle under traction on 64 % of moving samples")
    assert main(["inspect", str(path), "--phase", "braking"]) == 0
    assert "identifiability [creep_sign]: wheel slower than vehicle" in capsys.readouterr().out


def test_inspect_says_a_recording_without_creep_has_nothing_to_identify(tmp_path, capsys):
    """A vehicle speed computed from this wheel's own speed (creep 0 on every sample): fit refuses
    it with one line; inspect said only 'slip_range' and 'no_peak' of it, and now says what fit
    says, alone."""
    cols = stretches_si()
    cols["vehicle_speed"] = cols["wheel_speed"]
    path = save_recording(cols, LOCO_22E, tmp_path / "zero.csv")
    assert main(["inspect", str(path), "--json"]) == 0
    (remark,) = json.loads(capsys.readouterr().out)["identifiability"]
    assert remark["code"] == "zero_creep" and "nothing to identify" in remark["message"]
    assert main(["fit", str(path), "--method", "lm"]) == 2
    assert remark["message"] in capsys.readouterr().err


def test_inspect_notes_a_misspelled_sidecar_key_with_the_key_it_likely_meant(tmp_path, capsys):
    path = save_recording(stretches_si(), LOCO_22E, tmp_path / "typo.csv")
    path.with_suffix(".json").write_text('{"axle_lod_kg": 21000, "comment": "x"}')
    assert main(["inspect", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == [
        f"{path.with_suffix('.json')}: unknown key 'axle_lod_kg' ignored (did you mean 'axle_load_kg'?)",
        f"{path.with_suffix('.json')}: unknown key 'comment' ignored",
    ]


def test_text_groups_close_runs_of_one_reason():
    """Runs of one reason less than GROUP_WITHIN_S apart share a line with their count; a farther
    run of that reason, and other reasons in between, keep their own."""
    runs = [
        {"reason": "standstill", "start": 0.0, "end": 0.4, "samples": 41},
        {"reason": "torque and creep disagree", "start": 0.5, "end": 0.5, "samples": 1},
        {"reason": "standstill", "start": 0.6, "end": 0.6, "samples": 1},
        {"reason": "torque and creep disagree", "start": 0.9, "end": 0.95, "samples": 2},
        {"reason": "torque and creep disagree", "start": 2.0, "end": 2.0, "samples": 1},
        {"reason": "coasting", "start": 5.0, "end": 8.0, "samples": 301},
        {"reason": "coasting", "start": 9.5, "end": 9.7, "samples": 21},
    ]
    lines = [_excluded_line(g, 0.01) for g in _grouped(runs)]
    assert lines == [
        "  excluded standstill: 0–0.6 s, 42 samples in 2 stretches",
        "  excluded torque and creep disagree: 0.5–0.95 s, 3 samples in 2 stretches",
        "  excluded torque and creep disagree: 2–2 s, 1 sample",
        "  excluded coasting: 5–8 s, 301 samples",
        "  excluded coasting: 9.5–9.7 s, 21 samples",
    ]


def test_a_clipped_wheel_speed_is_named_by_every_command(tmp_path, capsys):
    """The independent generator's start (30 s, 50 Hz, realistic sensors) with its wheel speed
    clipped at 60 % of its largest value: 12.9 s of one exact value while the vehicle speed rises
    by 2 m/s (a 'converged' fit whose 95 % interval of mu_max missed the truth, said nowhere).
    inspect, fit and online name it (``stuck_signal``, with where); the unclipped run gets none."""
    rec = generate(0, effect="none", sensor="realistic", rate_hz=50.0, profile="start", duration_s=30.0)
    path = write(rec, tmp_path / "start.csv")
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    top = 0.6 * max(float(r[2]) for r in rows)
    clipped = tmp_path / "clipped.csv"
    clipped.write_text(
        "\n".join([lines[0], *(",".join([r[0], r[1], repr(min(float(r[2]), top)), r[3]]) for r in rows)])
        + "\n"
    )
    clipped.with_suffix(".json").write_text(path.with_suffix(".json").read_text())
    for command in (["inspect"], ["fit", "--method", "lm", "--single-law"], ["online"]):
        found = {}
        for name, file in (("clean", path), ("clipped", clipped)):
            assert main([command[0], str(file), *command[1:], "--json"]) == 0
            doc = json.loads(capsys.readouterr().out)
            found[name] = [
                w for w in doc.get("warnings", doc.get("identifiability")) if w["code"] == "stuck_signal"
            ]
        assert not found["clean"], command
        (warning,) = found["clipped"]
        assert (
            warning["message"].startswith("wheel_speed holds")
            and "at its largest value" in warning["message"]
        )
