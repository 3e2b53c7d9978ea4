"""Automatic selection of the samples the observer can use: standstill, coasting, braking, gaps,
direction changes; the observer runs per stretch and never bridges a gap."""

import json
import subprocess
import sys

import numpy as np
import pytest
from logger_data import SCALE, stretches_si, write_logger_file

from jadhesion.data.dataset import to_dataset
from jadhesion.data.recording import load_recording, save_recording
from jadhesion.data.segments import select, slice_recording
from jadhesion.data.selected import creep_sign_warning, selected_dataset
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.errors import RecordingError

EXCLUDED_TRACTION = [
    {"reason": "standstill", "start": 0.0, "end": 0.99, "samples": 100},
    {"reason": "coasting", "start": 5.0, "end": 5.99, "samples": 100},
    {"reason": "braking", "start": 6.0, "end": 8.99, "samples": 300},
]


@pytest.fixture(scope="module")
def logger(tmp_path_factory):
    return load_recording(write_logger_file(tmp_path_factory.mktemp("seg") / "log.csv"))


def test_selection_report_is_exact(logger):
    doc = select(logger, "traction").document()
    assert doc["phase"] == "traction" and doc["used"] == 700 and doc["samples"] == 1200
    assert doc["gaps"] == [[pytest.approx(8.99), pytest.approx(11.0)]]
    assert doc["stretches"] == [[0.0, pytest.approx(8.99)], [pytest.approx(11.0), pytest.approx(13.99)]]
    assert doc["counts"] == {"standstill": 100, "traction": 700, "coasting": 100, "braking": 300}
    assert [
        {**e, "start": round(e["start"], 6), "end": round(e["end"], 6)} for e in doc["excluded"]
    ] == EXCLUDED_TRACTION
    braking = select(logger, "braking").document()
    assert braking["used"] == 300
    assert [(e["reason"], e["samples"]) for e in braking["excluded"]] == [
        ("standstill", 100),
        ("traction", 400),
        ("coasting", 100),
        ("traction", 300),
    ]
    assert select(logger, "both").used == 1000


def test_observer_runs_per_stretch_and_never_bridges_the_gap(logger):
    data, sel = selected_dataset(logger, "both", creep="raw")
    # Per stretch by hand: the observer on each stretch alone, then the mask.
    parts = []
    for a, b in sel.stretches:
        d = to_dataset(slice_recording(logger, slice(a, b)), creep="raw")
        parts.append(np.asarray(d.adhesion)[sel.mask[a:b]])
    np.testing.assert_array_equal(np.asarray(data.adhesion), np.concatenate(parts))
    # Bridging the gap puts the 2 s step (2.1 -> 3 m/s) into the observer's filter: the first
    # samples after the gap are off by ~0.02; per stretch they start at the true 0.3.
    bridged = np.asarray(to_dataset(logger, creep="raw").adhesion)[sel.mask]
    assert abs(bridged[700] - 0.3) > 0.015 and abs(float(data.adhesion[700]) - 0.3) < 0.005
    mu = np.asarray(data.adhesion)  # the abrupt steps of the test signal give transients: medians
    assert [round(float(np.median(m)), 2) for m in (mu[:400], mu[400:700], mu[700:])] == [0.3, -0.3, 0.3]
    smoothed, _ = selected_dataset(logger, "traction")
    assert smoothed.creep.shape == (700,) and smoothed.creep_sd.shape == (700,)
    assert np.all(np.asarray(smoothed.creep) > 0.005)


def test_a_clean_recording_gives_exactly_to_dataset(tmp_path):
    cols = stretches_si()
    keep = slice(100, 500)  # the first traction stretch only
    rec = load_recording(
        save_recording({k: v[keep] for k, v in cols.items()}, LOCO_22E, tmp_path / "clean.csv")
    )
    data, sel = selected_dataset(rec)
    assert sel.complete and sel.document()["excluded"] == []
    for a, b in zip(data, to_dataset(rec), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_direction_change_and_short_stretch(tmp_path):
    n = 600
    t = np.arange(n) * 0.01
    v = np.where(t < 3.0, 1.0, -1.0) * np.minimum(1.0, 0.1 + np.abs(t - 3.0))  # reverses at 3 s
    torque = np.sign(v) * 0.3 * SCALE
    cols = {
        "time": np.r_[t, 10.0 + 0.01 * np.arange(10)],  # then 10 samples after a gap
        "vehicle_speed": np.r_[v, np.ones(10)],
        "wheel_speed": np.r_[v * 1.01, np.full(10, 1.01)],
        "traction_torque": np.r_[torque, np.full(10, 0.3 * SCALE)],
    }
    rec = load_recording(save_recording(cols, LOCO_22E, tmp_path / "rev.csv"))
    sel = select(rec, "traction")
    counts = sel.counts()
    assert counts["short stretch"] == 10
    moving = np.abs(v) >= 0.2
    t0, t1 = t[moving & (t < 3.0)][-1], t[moving & (t > 3.0)][0]  # the reversal between them
    assert counts["standstill"] == np.count_nonzero(~moving) == 19
    near = moving & (t >= t0 - 1.0) & (t <= t1 + 1.0)  # within 1 s of the reversal
    assert counts["direction change"] == np.count_nonzero(near)
    assert sel.used == counts["traction"] == n - 19 - np.count_nonzero(near)
    reverse = np.asarray(selected_dataset(rec)[0].creep)
    forward = np.count_nonzero(moving & ~near & (t < 3.0))
    assert np.all(reverse[:forward] > 0) and np.all(reverse[forward:] < 0)  # reverse traction: s < 0


def test_nothing_selected_and_bad_phase(logger):
    sub = slice_recording(logger, slice(0, 100))  # standstill only
    with pytest.raises(RecordingError, match=r"--phase traction selects no samples \(standstill 100\)"):
        selected_dataset(sub)
    with pytest.raises(RecordingError, match="--phase coast: expected one of traction, braking, both"):
        select(logger, "coast")


def _cli(tmp_path, *argv):
    return subprocess.run(
        [sys.executable, "-m", "jadhesion", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,  # the environment, and so the session's compilation cache (conftest.py), inherited
    )


def test_fit_json_reports_the_selection_and_fits_braking_alone(tmp_path):
    path = write_logger_file(tmp_path / "log.csv")
    proc = _cli(tmp_path, "fit", path, "--method", "lm", "--phase", "braking", "--single-law", "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    sel = doc["selection"]
    assert sel["phase"] == "braking" and sel["used"] == 300
    assert sel["counts"] == {"standstill": 100, "traction": 700, "coasting": 100, "braking": 300}
    before = set(tmp_path.iterdir())
    bad = _cli(tmp_path, "fit", path, "--method", "lm", "--phase", "coast")
    assert bad.returncode == 2 and bad.stdout == ""  # argparse: usage, then the one error line
    assert "argument --phase: invalid choice: 'coast'" in bad.stderr.splitlines()[-1]
    none = _cli(tmp_path, "fit", path, "--method", "lm", "--end", "0.9", "--json")
    assert none.returncode == 2 and none.stdout == "" and none.stderr.count("\n") == 1
    assert f"{path}: --phase traction selects no samples (standstill 91)" in none.stderr
    assert set(tmp_path.iterdir()) == before


def test_adhesion_column_is_ignored_when_raw_signals_are_present(tmp_path):
    from argparse import Namespace

    from jadhesion.cli.loading import load_from_args
    from jadhesion.data.observer import observe_adhesion

    cols = {k: v[100:500] for k, v in stretches_si().items()}
    bogus = save_recording({**cols, "adhesion": np.full(400, 0.9)}, LOCO_22E, tmp_path / "b.csv")
    args = Namespace(column=[], axle=None, missing="error", repeated_time="error", start=None, end=None)
    rec = load_from_args(args, bogus)
    assert rec.notes == (
        f"{bogus}: column 'adhesion' ignored: mu_hat is the observer's output of the raw signals",
    )
    mu = np.asarray(to_dataset(rec, creep="raw").adhesion)
    expected = observe_adhesion(cols["time"], cols["wheel_speed"], cols["traction_torque"], LOCO_22E)
    np.testing.assert_array_equal(mu, np.asarray(expected))
    # Without the raw signals (a fitting-dataset file) the column is mu_hat.
    ds = save_recording(
        {
            "vehicle_speed": cols["vehicle_speed"],
            "creepage": np.full(400, 0.01),
            "adhesion": np.full(400, 0.3),
        },
        LOCO_22E,
        tmp_path / "d.csv",
    )
    np.testing.assert_array_equal(np.asarray(to_dataset(load_recording(ds)).adhesion), 0.3)


def test_posterior_runs_on_the_selected_samples_and_refuses_the_observer_likelihood(tmp_path):
    path = write_logger_file(tmp_path / "log.csv")
    args = ("--walkers", "12", "--steps", "60", "--creep", "raw", "--single-law", "--json")  # the selection's
    proc = _cli(tmp_path, "posterior", path, *args)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["likelihood"] == "gauss" and doc["likelihood_note"].startswith("auto: Gaussian tempered")
    assert doc["selection"]["used"] == 700 == doc["tempering"]["samples"]
    bad = _cli(tmp_path, "posterior", path, "--steps", "60", "--likelihood", "observer")
    assert bad.returncode == 2 and bad.stdout == "" and bad.stderr.count("\n") == 1
    assert "--likelihood observer needs one contiguous series" in bad.stderr
    # where the excluded samples lie, so that --start/--end can keep them out
    first = doc["selection"]["excluded"][0]
    assert f"{first['reason']} at t = {first['start']:.6g}" in bad.stderr


def _swapped(cols, which):
    """``cols`` with wheel_speed and vehicle_speed exchanged on the samples ``which``."""
    return {
        **cols,
        "vehicle_speed": np.where(which, cols["wheel_speed"], cols["vehicle_speed"]),
        "wheel_speed": np.where(which, cols["vehicle_speed"], cols["wheel_speed"]),
    }


def test_speed_columns_swapped_on_most_moving_samples_are_named(logger, tmp_path):
    """The wheel slower than the vehicle under traction on most moving samples (> 50 %) is no
    contact: the selection says which columns to check. Of the 1100 moving samples, swapping the
    speeds on the first traction stretch (400, 36 %) stays below the threshold, on both traction
    stretches (700, 64 %) is named, and on every sample (braking too) leaves traction nothing,
    with the same hint in the error."""
    assert creep_sign_warning(logger, select(logger, "both")) is None
    cols = stretches_si()
    index = np.arange(cols["time"].size)
    traction = (index >= 100) & (index < 500)
    check = "are wheel_speed and vehicle_speed swapped, or the torque's sign inverted?"
    for which, expected in ((traction, None), (traction | (index >= 900), "traction on 64 %")):
        rec = load_recording(save_recording(_swapped(cols, which), LOCO_22E, tmp_path / "part.csv"))
        sel = select(rec, "both")
        assert sel.counts()["torque and creep disagree"] == which.sum()
        warning = creep_sign_warning(rec, sel)
        if expected is None:
            assert warning is None
        else:
            message = f"wheel slower than vehicle under {expected} of moving samples: {check}"
            assert warning == {"code": "creep_sign", "params": [], "message": message}
    rec = load_recording(save_recording(_swapped(cols, index >= 0), LOCO_22E, tmp_path / "all.csv"))
    with pytest.raises(RecordingError, match="selects no samples") as error:
        selected_dataset(rec)
    assert str(error.value).endswith(
        "; wheel slower than vehicle under traction on 64 % and wheel faster than vehicle under "
        f"braking on 27 % of moving samples: {check}"
    )
