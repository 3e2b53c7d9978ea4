"""A corpus of bad input (DESIGN §3): every malformed file and bad flag value → exit code 2, exactly
one line on stderr naming the file/column/row or the flag, nothing on stdout, nothing written."""

import json
import os
import subprocess
import sys
from argparse import Namespace

import numpy as np
import pytest

from jadhesion.cli import main
from jadhesion.cli.reproduce_run import ignored_flags

HEADER = "time,vehicle_speed,wheel_speed,traction_torque"


def good_rows(n=40):
    t = np.arange(n) * 0.02
    v = 0.6 + 0.01 * t
    return [f"{a:.4f},{b:.5f},{b * 1.05:.5f},{30000 + 100 * a:.1f}" for a, b in zip(t, v, strict=True)]


def csv(*rows, header=HEADER):
    return "\n".join([header, *rows]) + "\n"


ROWS = good_rows()
CREEP_HEADER = "creepage,vehicle_speed,adhesion"

#: name -> (file text, sidecar text or None, words the message must contain)
FILES = {
    "empty.csv": ("", None, ["empty.csv"]),
    "header_only.csv": (csv(), None, ["header_only.csv"]),
    "missing_torque.csv": (
        csv(*(",".join(r.split(",")[:3]) for r in ROWS), header="time,vehicle_speed,wheel_speed"),
        None,
        ["missing_torque.csv", "traction_torque"],
    ),
    "text_cell.csv": (
        csv(*ROWS[:5], "0.1,fast,0.6,30000", *ROWS[6:]),
        None,
        ["text_cell.csv", "vehicle_speed", "row"],
    ),
    "nan_cell.csv": (
        csv(*ROWS[:7], "0.14,0.6,nan,30000", *ROWS[8:]),
        None,
        ["nan_cell.csv", "wheel_speed", "row"],
    ),
    "inf_torque.csv": (
        csv(*ROWS[:3], "0.06,0.6,0.63,inf", *ROWS[4:]),
        None,
        ["inf_torque.csv", "traction_torque", "row"],
    ),
    "ragged.csv": (csv(*ROWS[:4], "0.08,0.6", *ROWS[5:]), None, ["ragged.csv", "row"]),
    "time_backwards.csv": (csv(*ROWS[:10], ROWS[3], *ROWS[11:]), None, ["time_backwards.csv", "time"]),
    "binary.csv": ("\x00\x01\x02garbage\xff", None, ["binary.csv"]),
    "bad_sidecar.csv": (csv(*ROWS), "{not json", ["bad_sidecar.json"]),
    "sidecar_type.csv": (
        csv(*ROWS),
        json.dumps({"axle_load_kg": "heavy"}),
        ["sidecar_type.json", "axle_load_kg"],
    ),
    "sidecar_negative.csv": (
        csv(*ROWS),
        json.dumps({"wheel_radius_m": -0.6}),
        ["sidecar_negative.json", "wheel_radius_m"],
    ),
    # contact numbers far outside any wheel's: k_eps NaN (was a traceback) or 0/inf (a junk fit)
    "sidecar_contact.csv": (
        csv(*ROWS),
        json.dumps({"contact_semi_axes_m": [1e-300, 1e-300]}),
        ["k_eps", "contact_semi_axes_m"],
    ),
    "sidecar_shear.csv": (
        csv(*ROWS),
        json.dumps({"shear_modulus_pa": 1e-300}),
        ["k_eps = 0", "shear_modulus_pa"],
    ),
    # mu_hat ~ 1e293: LM 'converged' at MAE 1e293, the population methods a NaN traceback
    "sidecar_inertia.csv": (
        csv(*ROWS),
        json.dumps({"wheelset_inertia_kgm2": 1e300}),
        ["sidecar_inertia.csv", "mu_hat", "wheelset_inertia_kgm2"],
    ),
    "three_rows.csv": (csv(*ROWS[:3]), None, ["three_rows.csv", "samples"]),
    "creep_too_few.csv": (
        csv("0.01,0.6,0.2", "0.02,0.6,0.25", header=CREEP_HEADER),
        None,
        ["creep_too_few.csv", "samples"],
    ),
    "zero_creep.csv": (  # vehicle speed taken from this wheel: no creep to identify
        csv(*(",".join([*r.split(",")[:2], r.split(",")[1], r.split(",")[3]]) for r in ROWS)),
        None,
        ["zero_creep.csv", "creep", "is 0", "vehicle_speed"],
    ),
    "subnormal_creep.csv": (  # a creep of 1e-310 was fitted, every parameter "at_bound"
        csv(*[f"1e-310,0.6,{0.2 + 0.001 * i}" for i in range(40)], header=CREEP_HEADER),
        None,
        ["subnormal_creep.csv", "creep", "is 0"],
    ),
    "weak_drive.csv": (  # every moving sample below the coasting drive: say what to check
        csv(*(",".join([*r.split(",")[:3], "1000"]) for r in ROWS)),
        None,
        ["weak_drive.csv", "coasting", "traction_torque", "axle_load_kg"],
    ),
    "creep_huge.csv": (  # no pair of plausible speeds gives it (was fitted; online ended nonfinite)
        csv(*[f"{0.01 * (i + 1) if i != 7 else 1e300},0.6,0.2" for i in range(20)], header=CREEP_HEADER),
        None,
        ["creep_huge.csv", "creepage", "row 8"],
    ),
    "creep_bad_adhesion.csv": (
        csv(*[f"{0.01 * (i + 1)},0.6,{'x' if i == 4 else 0.2}" for i in range(20)], header=CREEP_HEADER),
        None,
        ["creep_bad_adhesion.csv", "adhesion", "row"],
    ),
}


def run_main(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_exit_2(code, out, err, words):
    assert code == 2, err
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])


@pytest.mark.parametrize("name", sorted(FILES))
@pytest.mark.parametrize("command", ["fit", "posterior", "online"])
def test_malformed_file(tmp_path, capsys, name, command):
    text, sidecar, words = FILES[name]
    path = tmp_path / name
    path.write_text(text, encoding="utf-8", errors="surrogateescape")
    if sidecar is not None:
        path.with_suffix(".json").write_text(sidecar)
    before = set(tmp_path.iterdir())
    if command in ("posterior", "online") and name in ("three_rows.csv", "creep_too_few.csv"):
        words = [name]  # posterior and online state their own minimum
    code, out, err = run_main(capsys, [command, path, "--json"])
    assert_one_line_exit_2(code, out, err, words)
    assert set(tmp_path.iterdir()) == before


@pytest.mark.parametrize(
    "name, text, words",
    [
        ("text_cell.csv", FILES["text_cell.csv"][0], ["text_cell.csv", "vehicle_speed"]),
        (  # long enough for the diagnosis's own minimum, but no creep at all
            "zero_creep.csv",
            csv(*(",".join([*r.split(",")[:2], r.split(",")[1], r.split(",")[3]]) for r in good_rows(80))),
            ["zero_creep.csv", "is 0"],
        ),
    ],
)
def test_diagnose_malformed_file(tmp_path, capsys, name, text, words):
    path = tmp_path / name
    path.write_text(text)
    code, out, err = run_main(capsys, ["diagnose", path, "--json", "--report", tmp_path / "rep"])
    assert_one_line_exit_2(code, out, err, words)
    assert not (tmp_path / "rep").exists()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "ok.csv"
    path.write_text(csv(*good_rows(200)))
    return path


#: A sweep of one short fit per scenario (quick even where a check would let it run).
SMALL = ["--seeds", "1", "--samples", "100"]
#: command line (``{rec}`` = a valid recording, ``{tmp}`` = a fresh folder) -> flag named
FLAGS = [
    (["fit", "{rec}", "--pop-size", "0"], "--pop-size"),
    (["fit", "{rec}", "--pop-size", "-3"], "--pop-size"),
    (["fit", "{rec}", "--pop-size", "1"], "--pop-size"),
    (["fit", "{rec}", "--max-iter", "0"], "--max-iter"),
    (["fit", "{rec}", "--pop-size", "100000000"], "--pop-size"),  # was XLA's RESOURCE_EXHAUSTED
    (["fit", "{rec}", "--max-iter", "99999999999999999999"], "--max-iter"),  # was JAX's OverflowError
    (["fit", "{rec}", "--seed", "-1"], "--seed"),
    (
        ["fit", "{rec}", "--end", "-inf"],
        "--end -inf: expected a finite time",
    ),  # was argparse's "expected one argument" (exponent form too), which the check never saw
    (["fit", "{rec}", "--plot", "{rec}"], "--plot"),
    # a figure folder under a file: refused before the work (was an OSError line after it, no flag)
    (["fit", "{rec}", "--plot", "{rec}/sub"], "--plot"),
    (["inspect", "{rec}", "--plot", "{rec}/sub"], "--plot"),
    (["online", "{rec}", "--plot", "{rec}"], "--plot"),
    (["posterior", "{rec}", "--plot", "{rec}"], "--plot"),
    (["diagnose", "{rec}", "--report", "{rec}"], "--report"),
    (["reproduce", "online", "--runs", "1", "--plot", "{rec}"], "--plot"),
    (["posterior", "{rec}", "--walkers", "0"], "--walkers"),
    (["posterior", "{rec}", "--walkers", "514", "--steps", "50"], "--walkers"),  # above 512
    (["posterior", "{rec}", "--steps", "0"], "--steps"),
    # ar1 and observer sample 7 coordinates: emcee's RuntimeError traceback below 14 walkers
    (["posterior", "{rec}", "--likelihood", "ar1", "--walkers", "12", "--steps", "50"], "--walkers"),
    (["posterior", "{rec}", "--steps", "100000000"], "143 GiB"),  # was an ArrayMemoryError
    (["posterior", "{rec}", "--seed", "-1"], "--seed"),  # was NumPy's SeedSequence traceback
    (["diagnose", "{rec}", "--seed", "-1"], "--seed"),
    (["diagnose", "{rec}", "--replicas", "-1"], "--replicas"),  # was an AxisError
    (["diagnose", "{rec}", "--replicas", "99999999999999999999"], "--replicas"),  # never ended
    (["simulate", "--seed", "99999999999999999999999", "--out", "{tmp}/x.csv"], "--seed"),  # JAX's
    (["simulate", "--sensor-noise", "1e9", "--out", "{tmp}/x.csv"], "--sensor-noise"),
    (["simulate", "--scenario", "dry", "--out", "{tmp}/x.txt"], "--out"),
    (["simulate", "--scenario", "icy", "--out", "{tmp}/x.csv"], "icy"),
    (["simulate", "--scenario", "dry", "--effect", "nonsense", "--out", "{tmp}/x.csv"], "nonsense"),
    (["sweep", "--seeds", "0", "--out", "{tmp}/s.csv"], "--seeds"),
    (["sweep", "--seeds", "99999999999999999999999", "--out", "{tmp}/s.csv"], "--seeds"),
    (["sweep", "--scenarios", "dry,,wet", *SMALL, "--out", "{tmp}/s.csv"], "--scenarios"),  # was dry,wet
    (["sweep", "--scenarios", "dry", *SMALL, "--out", "{tmp}/s.txt"], "--out"),
    (["sweep", "--scenarios", "dry", *SMALL, "--out", "{tmp}/missing/s.csv"], "--out"),  # was made
    (["sweep", "--pop-size", "0", "--methods", "itlbo", "--out", "{tmp}/s.csv"], "--pop-size"),
    (["sweep", "--max-iter", "-1", "--methods", "itlbo", "--out", "{tmp}/s.csv"], "--max-iter"),
    (
        ["sweep", "--pop-size", "100000000", "--methods", "itlbo", *SMALL, "--out", "{tmp}/s.csv"],
        "--pop-size",
    ),
    (["sweep", "--max-iter", str(2**64), "--methods", "itlbo", *SMALL, "--out", "{tmp}/s.csv"], "--max-iter"),
    (["sweep", "--chunk-size", "0", "--out", "{tmp}/s.csv"], "--chunk-size"),
    (["sweep", "--samples", "0", "--out", "{tmp}/s.csv"], "--samples"),
    (["sweep", "--samples", "1000000000", "--out", "{tmp}/s.csv"], "--samples"),  # was XLA's 4 TB
    (["sweep", "--noise", "0.5,1e300", *SMALL, "--out", "{tmp}/s.csv"], "--noise"),  # ran, "converged"
    (["sweep", "--chunk-size", "1000000000", *SMALL, "--out", "{tmp}/s.csv"], "--chunk-size"),  # OOM-killed
    (["reproduce", "table2", "--seeds", "0"], "--seeds"),
    (["reproduce", "online", "--runs", "0"], "--runs"),
    (["reproduce", "online", "--runs", "100000000"], "--runs"),  # was XLA's RESOURCE_EXHAUSTED
    (["reproduce", "table2", "--seeds", "99999999999999999999"], "--seeds"),  # was an OverflowError
    (["reproduce", "table2", "--mcmc-steps", "99999999999999999999"], "--mcmc-steps"),  # a ValueError
    # simulate's range: inf ran 34 s to 'fit_polach: target MAE must be >= 0, got nan'
    (["reproduce", "table2", "--sensors", "realistic", "--sensor-noise", "inf"], "--sensor-noise"),
]


@pytest.mark.parametrize("argv, flag", FLAGS, ids=[" ".join(a[:1] + a[2:]) for a, _ in FLAGS])
def test_bad_flag_value(tmp_path, capsys, recording, argv, flag):
    work = tmp_path / "work"
    work.mkdir()
    argv = [a.replace("{rec}", str(recording)).replace("{tmp}", str(work)) for a in argv]
    code, out, err = run_main(capsys, argv)
    assert_one_line_exit_2(code, out, err, [flag])
    assert list(work.iterdir()) == []


def test_subprocess_bad_flag_and_file(tmp_path, recording):
    """The same through the installed entry point (no in-process state)."""
    env = dict(os.environ)
    bad = tmp_path / "binary.csv"
    bad.write_bytes(b"\x00\x01garbage")
    for argv, word in (
        (["fit", str(recording), "--max-iter", "0", "--json"], "--max-iter"),
        (["fit", str(bad), "--json"], "binary.csv"),
    ):
        proc = subprocess.run(
            [sys.executable, "-m", "jadhesion", *argv], env=env, capture_output=True, text=True, timeout=300
        )
        assert proc.returncode == 2 and proc.stdout == ""
        assert len(proc.stderr.strip().splitlines()) == 1 and word in proc.stderr


def test_lm_says_it_ignores_a_population_budget(capsys, recording):
    """``--max-iter``/``--pop-size`` with ``--method lm`` (no such budget: it stops at its own
    convergence test) are said on stderr, not silently dropped, and the fit runs as without them."""
    code, out, err = run_main(
        capsys, ["fit", str(recording), "--method", "lm", "--max-iter", "5000", "--json"]
    )
    assert code == 0 and json.loads(out)["method"] == "lm"
    assert "--max-iter" in err and "ignored" in err and "--pop-size" not in err


def test_fit_out_onto_a_directory_is_refused_before_anything_is_written(tmp_path, capsys, recording):
    """``--out`` naming an existing directory: one line naming the flag, before the fit (was an
    OSError naming a temporary file after it, with ``--plot``'s figure already written)."""
    (tmp_path / "table.csv").mkdir()
    argv = ["fit", recording, "--method", "lm", "--out", tmp_path / "table.csv", "--plot", tmp_path / "fig"]
    code, out, err = run_main(capsys, argv)
    assert_one_line_exit_2(code, out, err, ["--out", "is a directory"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_fit_keep_going_names_the_sidecar_whose_contact_is_unusable(tmp_path, capsys, recording):
    """A sidecar whose contact gives no k_eps skips its file, naming that sidecar, and the other
    files are fitted (was a NaN traceback ending the whole call)."""
    bad = tmp_path / "bad.csv"
    bad.write_text(recording.read_text())
    bad.with_suffix(".json").write_text(json.dumps({"wheel_load_n": 1e-300}))
    code, out, err = run_main(capsys, ["fit", recording, bad, "--method", "lm", "--keep-going", "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert [f["file"] for f in doc["fits"]] == [str(recording)]
    assert [s["file"] for s in doc["skipped"]] == [str(bad)] and "bad.json" in doc["skipped"][0]["error"]


def test_kiencke_fit_says_it_draws_no_figure(tmp_path, capsys, recording):
    """``--plot`` with ``--model kiencke`` (fit.png draws a Polach curve): a warning, not a silently
    missing figure; ``--single-law`` (Kiencke has no slip law) is said to do nothing, likewise."""
    argv = ["fit", recording, "--model", "kiencke", "--method", "lm", "--plot", tmp_path / "fig", "--json"]
    code, out, err = run_main(capsys, [*argv, "--single-law"])
    assert code == 0 and json.loads(out)["params"].keys() == {"p1", "p2", "a_s"}
    assert "--plot" in err and "kiencke" in err and not (tmp_path / "fig").exists()
    assert "--single-law has no effect with --model kiencke" in err


@pytest.mark.parametrize("second", ["other/ok.csv", "ok.csv"])
def test_fit_plot_refuses_two_files_that_would_write_one_figure(tmp_path, capsys, recording, second):
    """Several files with ``--plot`` write ``STEM.fit.png`` each: two files of one stem (or one file
    twice) are refused before any work, naming both; the second figure silently replaced the first."""
    other = recording.parent / second
    other.parent.mkdir(exist_ok=True)
    if other != recording:
        other.write_text(recording.read_text())
    argv = ["fit", recording, other, "--method", "lm", "--plot", tmp_path / "fig"]
    code, out, err = run_main(capsys, argv)
    assert_one_line_exit_2(code, out, err, ["--plot", "ok.fit.png", str(other)])
    assert not (tmp_path / "fig").exists()


def test_reproduce_says_which_flags_its_target_ignores(capsys):
    """A flag of the other target (``--seeds`` with ``online``), ``--mcmc-steps`` with
    ``--no-mcmc`` or ``--sensor-noise`` on clean sensors: a warning, not silently dropped."""
    code, out, err = run_main(capsys, ["reproduce", "online", "--runs", "1", "--seeds", "3", "--json"])
    assert code == 0 and json.loads(out) and "--seeds" in err and "ignored" in err
    table2 = dict(target="table2", seeds=20, runs=1000, no_mcmc=False, mcmc_steps=None, sensors="clean")
    assert ignored_flags(Namespace(**table2, sensor_noise=1.0)) == []
    notes = ignored_flags(
        Namespace(**{**table2, "runs": 5, "no_mcmc": True, "mcmc_steps": 40}, sensor_noise=2.0)
    )
    assert [n.split()[0] for n in notes] == ["--runs:", "--mcmc-steps", "--sensor-noise"]


def test_fit_out_onto_a_recording_fitted_is_refused(tmp_path, capsys, recording):
    """``--out`` naming the recording itself: refused, the recording kept (the table silently
    replaced it)."""
    copy = tmp_path / "run.csv"
    copy.write_text(recording.read_text())
    code, out, err = run_main(capsys, ["fit", copy, "--method", "lm", "--out", copy])
    assert_one_line_exit_2(code, out, err, ["--out", "overwritten"])
    assert copy.read_text() == recording.read_text()
