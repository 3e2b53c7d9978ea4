"""Recording CSV + sidecar: round trip, accepted layouts, and one-line validation errors that name the
file, the column and the row (DESIGN §3)."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jadhesion.cli.recording_options import MISSING
from jadhesion.data.dataset import PolachDataset, to_dataset
from jadhesion.data.observer import observe_adhesion
from jadhesion.data.recording import (
    MISSING_POLICIES,
    Recording,
    load_recording,
    save_recording,
    vehicle_sidecar,
)
from jadhesion.data.validate import MAX_SPEED
from jadhesion.data.vehicle import LOCO_22E, Vehicle
from jadhesion.errors import InputError, RecordingError
from jadhesion.models.kinematics import SPEED_FLOOR

DRY = np.array([0.4288, 1.0, 0.3555, 0.3575, 0.1316])
HEADER = "time,vehicle_speed,wheel_speed,traction_torque"


def _raw_columns(n=40):
    t = np.arange(n) * 0.02
    v = 0.6 + 0.01 * np.sin(t)
    s = np.geomspace(1e-3, 0.5, n)
    mu = 0.3 * np.tanh(s / 0.01)
    torque = mu * LOCO_22E.axle_weight_n * LOCO_22E.wheel_radius_m
    return {"time": t, "vehicle_speed": v, "wheel_speed": v * (1 + s), "traction_torque": torque}


def _raw_text(n=30, edit=None):
    """A valid raw CSV as lines; ``edit(rows)`` may change the data rows (lists of str)."""
    cols = _raw_columns(n)
    rows = [[repr(float(cols[c][i])) for c in cols] for i in range(n)]
    if edit is not None:
        edit(rows)
    return HEADER + "\n" + "\n".join(",".join(r) for r in rows) + "\n"


def _set(row, col, value):
    def edit(rows):
        rows[row - 1][HEADER.split(",").index(col)] = value

    return edit


def _error(path) -> str:
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    message = str(info.value)
    assert "\n" not in message and message.strip() == message
    assert isinstance(info.value, InputError)  # the CLI turns it into exit code 2
    return message


# ----------------------------------------------------------------------------------- round trip


def test_round_trip_is_exact(tmp_path):
    cols = _raw_columns(200)
    cols["time"] = cols["time"] + 1e-17 * np.arange(200)  # values that need 17 digits
    cols["adhesion"] = np.random.default_rng(0).normal(0.3, 0.01, 200)
    vehicle = LOCO_22E.replace(wheel_radius_m=0.57, contact_semi_axes_m=(0.008, 0.005), name="x 1")
    path = save_recording(cols, vehicle, tmp_path / "run.csv", extra_sidecar={"scenario": "dry"})
    rec = load_recording(path)
    assert isinstance(rec, Recording) and rec.path == tmp_path / "run.csv"
    assert list(rec.columns) == list(cols)
    for name, values in cols.items():
        assert rec.columns[name].dtype == np.float64
        np.testing.assert_array_equal(rec.columns[name], values)
    assert rec.vehicle == vehicle
    assert rec.sidecar["scenario"] == "dry"
    assert rec.notes == (f"{tmp_path / 'run.json'}: unknown key 'scenario' ignored",)
    assert json.loads((tmp_path / "run.json").read_text()) == {**vehicle_sidecar(vehicle), "scenario": "dry"}


def test_save_rejects_ragged_columns(tmp_path):
    with pytest.raises(ValueError, match="rows"):
        save_recording({"a": [1.0, 2.0], "b": [1.0]}, LOCO_22E, tmp_path / "x.csv")
    with pytest.raises(ValueError, match="header"):
        save_recording({"a,b": [1.0]}, LOCO_22E, tmp_path / "x.csv")
    assert not list(tmp_path.iterdir())  # nothing written


def test_default_vehicle_without_sidecar(tmp_path):
    (tmp_path / "data.csv").write_text(_raw_text())
    rec = load_recording(tmp_path / "data.csv")
    assert rec.vehicle == LOCO_22E and rec.sidecar == {} and rec.notes == ()
    assert rec.has_raw_signals and not rec.has_adhesion and rec.n_samples == 30


# ------------------------------------------------------------------------------ fitting datasets


def test_creepage_only_dataset_needs_no_time(tmp_path):
    s = np.array([0.001, 0.01, -0.02, 0.3])
    v = np.array([0.6, 0.0, 1.2, 2.0])  # standstill allowed
    mu = np.array([0.1, 0.3, -0.35, 0.33])
    save_recording({"creepage": s, "vehicle_speed": v, "adhesion": mu}, LOCO_22E, tmp_path / "ds.csv")
    ds = to_dataset(load_recording(tmp_path / "ds.csv"))
    assert isinstance(ds, PolachDataset)
    np.testing.assert_array_equal(np.asarray(ds.creep), s)
    np.testing.assert_array_equal(np.asarray(ds.adhesion), mu)
    np.testing.assert_array_equal(np.asarray(ds.vehicle_speed), v)
    np.testing.assert_allclose(np.asarray(ds.slip), s * np.maximum(np.abs(v), SPEED_FLOOR), rtol=1e-15)
    assert float(ds.k_eps) == pytest.approx(LOCO_22E.k_eps(), rel=1e-15)


def test_slip_velocity_dataset(tmp_path):
    w = np.array([0.001, 0.01, -0.02])
    v = np.array([0.5, 1.0, 0.0])
    (tmp_path / "d.csv").write_text(
        "slip_velocity,vehicle_speed,adhesion,comment\n"
        + "".join(
            f"{float(a)!r},{float(b)!r},0.2,run {i}\n" for i, (a, b) in enumerate(zip(w, v, strict=True))
        )
    )
    rec = load_recording(tmp_path / "d.csv")
    assert "comment" not in rec.columns and "'comment'" in rec.notes[0]  # text column ignored
    ds = to_dataset(rec)
    np.testing.assert_array_equal(np.asarray(ds.slip), w)
    np.testing.assert_allclose(np.asarray(ds.creep), w / np.maximum(v, SPEED_FLOOR), rtol=1e-15)


def test_raw_recording_runs_the_observer_with_the_sidecar_vehicle(tmp_path):
    cols = _raw_columns(20)
    vehicle = LOCO_22E.replace(wheel_radius_m=0.59)
    save_recording(cols, vehicle, tmp_path / "r.csv")
    ds = to_dataset(load_recording(tmp_path / "r.csv"), observer_variant="filtered_torque", creep="raw")
    expected = observe_adhesion(
        cols["time"], cols["wheel_speed"], cols["traction_torque"], vehicle, "filtered_torque"
    )
    np.testing.assert_array_equal(np.asarray(ds.adhesion), np.asarray(expected))
    w = cols["wheel_speed"] - cols["vehicle_speed"]
    np.testing.assert_allclose(np.asarray(ds.creep), w / cols["vehicle_speed"], rtol=1e-14)


def test_negative_speeds_and_extra_columns_are_accepted(tmp_path):
    cols = _raw_columns(20)
    cols["vehicle_speed"] = -cols["vehicle_speed"]  # running in reverse
    cols["wheel_speed"] = -cols["wheel_speed"]
    cols["traction_torque"] = -cols["traction_torque"]
    cols["motor_current"] = np.full(20, np.nan)  # unknown columns are carried, not checked
    save_recording(cols, LOCO_22E, tmp_path / "rev.csv")
    rec = load_recording(tmp_path / "rev.csv")
    assert np.isnan(rec.columns["motor_current"]).all()


def test_blank_and_comment_lines_are_skipped_and_lines_reported(tmp_path):
    text = _raw_text(5).splitlines()
    text = ["# recorded 2024-01-01", text[0], "", text[1], text[2], "", text[3] + ",9", text[4]]
    (tmp_path / "c.csv").write_text("\n".join(text) + "\n")
    msg = _error(tmp_path / "c.csv")
    assert "row 3 (line 7)" in msg and "5 fields" in msg and "4 columns" in msg


# ----------------------------------------------------------------------------------- validation


CASES = {
    "text": (
        _raw_text(30, _set(17, "vehicle_speed", "abc")),
        ["column 'vehicle_speed', row 17 (line 18)", "'abc' is not a number"],
    ),
    "empty cell": (
        _raw_text(30, _set(4, "wheel_speed", " ")),
        ["column 'wheel_speed', row 4 (line 5)", "empty cell"],
    ),
    "nan": (
        _raw_text(30, _set(3, "vehicle_speed", "nan")),
        ["column 'vehicle_speed', row 3", "'nan' is not a finite number"],
    ),
    "inf": (
        _raw_text(30, _set(9, "traction_torque", "-inf")),
        ["column 'traction_torque', row 9", "not a finite number"],
    ),
    "field count": (_raw_text(30, lambda rows: rows[4].pop()), ["row 5 (line 6)", "3 fields", "4 columns"]),
    "extra field": (_raw_text(30, lambda rows: rows[0].append("1")), ["row 1 (line 2)", "5 fields"]),
    "time equal": (
        _raw_text(30, _set(4, "time", "0.04")),
        ["column 'time', row 4", "not after the previous row's 0.04", "strictly increase"],
    ),
    "time decreasing": (_raw_text(30, _set(12, "time", "0.0")), ["column 'time', row 12"]),
    "km/h": (
        _raw_text(30, lambda rows: [r.__setitem__(1, repr(float(r[1]) * 140)) for r in rows]),
        [
            "column 'vehicle_speed', row 1",
            "looks like km/h? map it with --column vehicle_speed=vehicle_speed[km/h]",
        ],
    ),
    "wheel km/h": (
        _raw_text(30, lambda rows: [r.__setitem__(2, repr(float(r[1]) * 3.6)) for r in rows]),
        [
            "column 'wheel_speed', row 1",
            "wheel_speed looks like km/h",
            "--column wheel_speed=wheel_speed[km/h]",
        ],
    ),
    "wheel rad/s": (  # the 22E's wheel radius 0.625 m: a ratio 1.6
        _raw_text(30, lambda rows: [r.__setitem__(2, repr(float(r[1]) / 0.625)) for r in rows]),
        [
            "column 'wheel_speed', row 1",
            "ratio is 1.6 ",
            "wheel_speed looks like rad/s",
            "wheel_speed[rad/s]",
        ],
    ),
    "wheel rpm": (
        _raw_text(
            30, lambda rows: [r.__setitem__(2, repr(float(r[1]) / 0.625 * 60 / 6.283185)) for r in rows]
        ),
        ["wheel_speed looks like rpm while the other speed is m/s", "wheel_speed[rpm]"],
    ),
    "wheel rpm beyond 70": (  # 12 m/s: 183 rpm, read as m/s beyond the plausible speed
        _raw_text(
            30,
            lambda rows: [
                (
                    r.__setitem__(1, repr(float(r[1]) * 20)),
                    r.__setitem__(2, repr(float(r[1]) / 0.625 * 9.549)),
                )
                for r in rows
            ],
        ),
        ["wheel_speed looks like rpm", "wheel_speed[rpm]"],
    ),
    "speed ratio": (  # no unit makes 2.8
        _raw_text(30, lambda rows: [r.__setitem__(2, repr(float(r[1]) * 2.8)) for r in rows]),
        [
            "column 'wheel_speed', row 1",
            "ratio is 2.8 (creepage 1.8)",
            "implausible for an adhesion recording",
        ],
    ),
    "logger names": (
        "t_ms,v_kmh,n_rpm,M_kNm\n0,3.6,60,5\n",
        ["missing columns 'time', 'vehicle_speed', 'wheel_speed', 'traction_torque'", "--column CANONICAL"],
    ),
    "kNm": (
        _raw_text(30, lambda rows: [r.__setitem__(3, repr(float(r[3]) / 1000)) for r in rows]),
        [
            "column 'traction_torque', row 26 (line 27)",
            "implies mu = 0.0003",
            "looks like kN·m? map it with --column traction_torque=traction_torque[kN*m]",
        ],
    ),
    "huge torque": (
        _raw_text(30, _set(2, "traction_torque", "1e7")),
        ["column 'traction_torque', row 2", "implausible"],
    ),
    "no header": ("0,1,1,5\n0.1,1,1,5\n", ["no header row", "line 1"]),
    "header only": (HEADER + "\n", ["no data rows"]),
    "duplicate": (
        "time,time,vehicle_speed,wheel_speed,traction_torque\n1,2,3,4,5\n",
        ["'time' appears twice"],
    ),
    "empty name": ("time,,vehicle_speed\n1,2,3\n", ["column 2 has an empty name"]),
    "missing raw": (
        "time,vehicle_speed\n0,1\n",
        [
            "missing columns 'wheel_speed', 'traction_torque'",
            "present: time, vehicle_speed",
            "time, vehicle_speed, wheel_speed, traction_torque (raw signals)",
        ],
    ),
    "missing creep": (
        "vehicle_speed,adhesion\n1,0.2\n",
        [
            "missing column 'creepage' or 'slip_velocity'",
            "fitting dataset",
            "present: vehicle_speed, adhesion",
        ],
    ),
    "missing speed": ("creepage,adhesion\n0.1,0.2\n", ["missing column 'vehicle_speed'"]),
    "adhesion percent": (
        "creepage,vehicle_speed,adhesion\n0.01,1,0.3\n0.02,1,35\n",
        ["column 'adhesion', row 2 (line 3)", "implausible"],
    ),
    "dataset nan": (
        "creepage,vehicle_speed,adhesion\n0.01,1,0.3\nnan,1,0.3\n",
        ["column 'creepage', row 2", "finite"],
    ),
    "empty": ("", ["empty"]),
    "blank": ("\n  \n\n", ["empty"]),
    "comments only": ("# nothing\n", ["no header row"]),
    "unclosed quote": (HEADER + '\n0,1,1,"5\n', ["row 1"]),
    "bad date-time": (
        _raw_text(
            30, lambda rows: [r.__setitem__(0, f"2026-05-01T08:00:{i:02d}") for i, r in enumerate(rows)]
        ).replace("08:00:07", "08:00:7x"),
        ["column 'time', row 8 (line 9)", "'2026-05-01T08:00:7x' is not an ISO 8601 date-time like row 1's"],
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_validation_message_names_file_column_row(tmp_path, case):
    text, expected = CASES[case]
    path = tmp_path / "data.csv"
    path.write_text(text, encoding="utf-8")
    msg = _error(path)
    assert msg.startswith(f"{path}: ")
    for part in expected:
        assert part in msg, msg


def test_iso_time_stamps_are_seconds(tmp_path):
    """A logger's ISO 8601 time stamps (with or without an offset; none: UTC) read as seconds since
    1970 UTC, as Parquet timestamps are, and times of day as seconds since midnight: the same steps
    as the numeric file, and a note. A unit on such a column is refused."""
    plain = tmp_path / "plain.csv"
    plain.write_text(_raw_text(30), encoding="utf-8")
    ref = load_recording(plain)
    for stamp, epoch, kind in (
        ("2026-05-01T08:00:{:09.6f}", 1777622400.0, "date-times"),
        ("2026-05-01 10:00:{:09.6f}+02:00", 1777622400.0, "date-times"),
        ("08:00:{:09.6f}", 28800.0, "times of day"),
    ):
        dated = tmp_path / "dated.csv"
        rows = _raw_text(30).splitlines()
        rows[1:] = [stamp.format(float(r.split(",")[0])) + r[r.index(",") :] for r in rows[1:]]
        dated.write_text("\n".join(rows) + "\n", encoding="utf-8")
        rec = load_recording(dated)
        np.testing.assert_allclose(rec.columns["time"] - epoch, ref.columns["time"], atol=1e-6)
        for col in ("vehicle_speed", "wheel_speed", "traction_torque"):
            np.testing.assert_array_equal(rec.columns[col], ref.columns[col])
        assert any(f"read as ISO 8601 {kind}" in n for n in rec.notes)
    with pytest.raises(
        RecordingError, match=r"holds time stamps, read in seconds: map it without the unit \[ms\]"
    ):
        load_recording(dated, columns=("time=time[ms]",))
    bad = dated.read_text().replace("08:00:00.100000", "08:00:00.1x")
    dated.write_text(bad, encoding="utf-8")
    with pytest.raises(
        RecordingError, match=r"row 6 \(line 7\): '08:00:00.1x' is not an ISO 8601 time of day like"
    ):
        load_recording(dated)


def test_missing_values_are_skipped_as_gaps_on_request(tmp_path):
    """A logger's dropouts (an empty cell, NaN, NA, null, '-') stop the load by default, naming the
    first; with ``missing="skip"`` each such row is left out (a gap in time), the rest read exactly
    as written, a note counts them and names the first. A column the recording does not use may
    have holes either way; inf stays an error; a file of holes is one error line."""

    def edit(rows):
        rows[3][2], rows[9][1], rows[10][3], rows[20][0] = "", "NaN", "NA", "-"
        for r in rows:
            r.append("" if r is rows[5] else "1")  # an unused column with a hole

    path = tmp_path / "drop.csv"
    path.write_text(_raw_text(30, edit).replace(HEADER, HEADER + ",note", 1))
    assert "column 'time', row 21 (line 22): '-' is not a number (a missing value; --missing skip" in _error(
        path
    )
    rec = load_recording(path, missing="skip")
    full = _raw_columns(30)
    kept = np.setdiff1d(np.arange(30), [3, 9, 10, 20])
    for c in full:
        np.testing.assert_array_equal(rec.columns[c], full[c][kept])
    (note,) = [n for n in rec.notes if "skipped" in n]
    assert "4 of 30 rows skipped" in note and "row 4 (line 5), column 'wheel_speed'" in note
    inf = tmp_path / "inf.csv"
    inf.write_text(_raw_text(30, _set(9, "traction_torque", "-inf")))
    with pytest.raises(RecordingError, match="'-inf' is not a finite number"):
        load_recording(inf, missing="skip")
    assert MISSING == MISSING_POLICIES  # the command line offers what the reader knows
    with pytest.raises(ValueError, match="missing must be one of"):
        load_recording(path, missing="drop")
    holes = tmp_path / "holes.csv"
    holes.write_text(_raw_text(30, lambda rows: [r.__setitem__(1, "") for r in rows]))
    with pytest.raises(RecordingError, match="every row has a missing value"):
        load_recording(holes, missing="skip")


def test_rows_are_named_as_the_file_numbers_them_after_rows_are_skipped(tmp_path):
    """Two rows skipped for a missing value (rows 4 and 10), then a time that goes back at row 21:
    the error names row 21 (line 22), not the 19th row kept; a repeated stamp dropped after the
    skip is named by its own row too."""

    def edit(rows):
        rows[3][2], rows[9][1] = "", "NaN"
        rows[20][0] = rows[18][0]  # row 21 goes back to row 19's time

    path = tmp_path / "back.csv"
    path.write_text(_raw_text(30, edit))
    with pytest.raises(RecordingError, match=r"column 'time', row 21 \(line 22\): time"):
        load_recording(path, missing="skip")

    def repeat(rows):
        rows[3][2] = ""
        rows[15][0] = rows[14][0]  # row 16 repeats row 15's stamp

    path.write_text(_raw_text(30, repeat))
    rec = load_recording(path, missing="skip", repeated_time="drop")
    assert any("the first at row 16 (line 17)" in n for n in rec.notes) and rec.n_samples == 28


def test_a_spreadsheet_error_value_is_a_missing_value_not_a_comment(tmp_path):
    """Excel writes '#N/A' (or '#DIV/0!', '#VALUE!') where a formula found nothing. In the first
    column such a row was taken for a '#' comment and dropped without a word (its samples lost, a
    gap in time); it is a missing value wherever it stands: an error naming it by default, a
    skipped row counted in the note with ``missing="skip"``. A real comment line still is one."""
    path = tmp_path / "xl.csv"
    path.write_text(
        _raw_text(30, lambda rows: (rows[6].__setitem__(0, "#N/A"), rows[12].__setitem__(0, "#DIV/0!")))
    )
    assert "column 'time', row 7 (line 8): '#N/A' is not a number (a missing value" in _error(path)
    rec = load_recording(path, missing="skip")
    assert rec.n_samples == 28 and any("2 of 30 rows skipped" in n for n in rec.notes)
    commented = tmp_path / "comment.csv"
    commented.write_text(_raw_text(30).replace(HEADER + "\n", HEADER + "\n# logger v2\n", 1))
    assert load_recording(commented).n_samples == 30


def test_missing_file_and_directory(tmp_path):
    assert "not found" in _error(tmp_path / "nope.csv") and "nope.csv" in _error(tmp_path / "nope.csv")
    assert "directory" in _error(tmp_path)


@pytest.mark.parametrize(
    "content,expected",
    [
        (b"time,vehicle_speed\x00\x01\x02", "binary data (NUL byte at byte 18)"),
        ((HEADER + "\n0,1,1,\xe9\n").encode("latin-1"), "not UTF-8 text (undecodable byte 0xe9"),
        (b"\x89PNG\r\n\x1a\n" + bytes(range(256)), "binary data"),
    ],
)
def test_binary_files(tmp_path, content, expected):
    (tmp_path / "data.csv").write_bytes(content)
    msg = _error(tmp_path / "data.csv")
    assert "data.csv" in msg and expected in msg


def test_utf8_bom_and_crlf_are_accepted(tmp_path):
    (tmp_path / "w.csv").write_bytes(b"\xef\xbb\xbf" + _raw_text(5).replace("\n", "\r\n").encode())
    assert load_recording(tmp_path / "w.csv").n_samples == 5


def test_bad_row_found_exactly_in_a_large_file(tmp_path):
    n = 100_000
    cols = _raw_columns(n)
    cols["traction_torque"] = np.full(n, 4e4)
    save_recording(cols, LOCO_22E, tmp_path / "big.csv")
    assert load_recording(tmp_path / "big.csv").n_samples == n
    lines = (tmp_path / "big.csv").read_text().splitlines()
    lines[99_997] = lines[99_997].replace(lines[99_997].split(",")[2], "1.2.3")  # line 99998
    (tmp_path / "big.csv").write_text("\n".join(lines) + "\n")
    assert "column 'wheel_speed', row 99997 (line 99998): '1.2.3'" in _error(tmp_path / "big.csv")


def test_max_speed_is_documented_and_adjustable(tmp_path):
    text = _raw_text(10, _set(5, "vehicle_speed", "75"))
    (tmp_path / "f.csv").write_text(text)
    assert f"exceeds the plausible {MAX_SPEED:g} m/s" in _error(tmp_path / "f.csv")
    assert load_recording(tmp_path / "f.csv", max_speed=100.0).n_samples == 10


# ---------------------------------------------------------------------------------------- sidecar


SIDECAR_CASES = {
    "not json": ("{'wheel_radius_m': 0.6}", ["not valid JSON", "line 1, column 2"]),
    "truncated": ('{"wheel_radius_m": 0.6', ["not valid JSON"]),
    "empty": ("", ["sidecar is empty"]),
    "list": ("[0.6]", ["must be a JSON object", "list"]),
    "string value": ('{"wheel_radius_m": "0.6"}', ["key 'wheel_radius_m'", "expected a number", 'str "0.6"']),
    "bool value": ('{"axle_load_kg": true}', ["key 'axle_load_kg'", "expected a number"]),
    "negative": ('{"wheel_radius_m": -0.6}', ["key 'wheel_radius_m'", "must be positive"]),
    "zero inertia": ('{"wheelset_inertia_kgm2": 0}', ["key 'wheelset_inertia_kgm2'", "positive"]),
    "radius in mm": (
        '{"wheel_radius_m": 500}',
        ["key 'wheel_radius_m'", "outside the plausible 0.1–2; in mm?"],
    ),
    "load in t": ('{"axle_load_kg": 22.5}', ["key 'axle_load_kg'", "22.5 is outside the plausible", "in t?"]),
    "load in N": ('{"axle_load_kg": 220725}', ["key 'axle_load_kg'", "500–100000; in N?"]),
    "tiny radius": ('{"wheel_radius_m": 0.01}', ["key 'wheel_radius_m'", "outside the plausible 0.1–2"]),
    "nan": ('{"axle_load_kg": NaN}', ["key 'axle_load_kg'", "not a finite number"]),
    "poisson": ('{"poisson_ratio": 0.7}', ["key 'poisson_ratio'", "outside [0, 0.5)"]),
    "name": ('{"name": 22}', ["key 'name'", "expected a string"]),
    "axes one": (
        '{"contact_semi_axes_m": [0.008]}',
        ["key 'contact_semi_axes_m'", "two positive numbers", "[0.008]"],
    ),
    "axes negative": ('{"contact_semi_axes_m": [0.008, -0.005]}', ["two positive numbers"]),
    "axes text": ('{"contact_semi_axes_m": "8 mm x 5 mm"}', ["two positive numbers"]),
    "axes three": ('{"contact_semi_axes_m": [1, 2, 3]}', ["two positive numbers"]),
}


@pytest.mark.parametrize("case", sorted(SIDECAR_CASES))
def test_sidecar_errors_name_sidecar_and_key(tmp_path, case):
    text, expected = SIDECAR_CASES[case]
    (tmp_path / "data.csv").write_text(_raw_text(5))
    (tmp_path / "data.json").write_text(text)
    msg = _error(tmp_path / "data.csv")
    assert msg.startswith(f"{tmp_path / 'data.json'}: ")
    for part in expected:
        assert part in msg, msg


def test_binary_sidecar(tmp_path):
    (tmp_path / "data.csv").write_text(_raw_text(5))
    (tmp_path / "data.json").write_bytes(b"\x00\x01")
    assert "data.json: binary data" in _error(tmp_path / "data.csv")


def test_sidecar_overrides_reach_vehicle(tmp_path):
    (tmp_path / "data.csv").write_text(_raw_text(5))
    (tmp_path / "data.json").write_text(
        json.dumps(
            {
                "wheel_radius_m": 0.5,
                "axle_load_kg": 20000,
                "name": "test loco",
                "wheel_load_n": None,
                "comment": "ignored",
            }
        )
    )
    rec = load_recording(tmp_path / "data.csv")
    assert rec.vehicle == Vehicle(name="test loco", wheel_radius_m=0.5, axle_load_kg=20000.0)
    assert rec.notes == (f"{tmp_path / 'data.json'}: unknown key 'comment' ignored",)
    # A smaller wheel: a shorter contact in the rolling direction and a different k_eps.
    assert float(rec.vehicle.contact().a) < float(LOCO_22E.contact().a)
    assert rec.vehicle.k_eps() != pytest.approx(LOCO_22E.k_eps(), rel=1e-3)
    # Contact overrides replace Hertz.
    (tmp_path / "data.json").write_text(
        json.dumps({"contact_semi_axes_m": [0.007, 0.006], "shear_modulus_pa": 8e10})
    )
    rec = load_recording(tmp_path / "data.csv")
    c = rec.vehicle.contact()
    assert (float(c.a), float(c.b)) == (0.007, 0.006)
    assert rec.vehicle.shear_modulus == 8e10
    assert rec.vehicle.k_eps() == pytest.approx(
        Vehicle(contact_semi_axes_m=(0.007, 0.006), shear_modulus_pa=8e10).k_eps(), rel=1e-15
    )


# ------------------------------------------------------------------------------------- fuzzing


_alphabet = st.sampled_from(
    list('0123456789.,-+eE\n\r "#tnaiNf')
    + ["time", "vehicle_speed", "wheel_speed", "traction_torque", "creepage", "adhesion", "1e9"]
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    data=st.one_of(
        st.binary(max_size=400),
        st.lists(_alphabet, max_size=80).map(lambda x: "".join(x).encode()),
        st.lists(_alphabet, max_size=60).map(lambda x: (HEADER + ",adhesion\n" + "".join(x)).encode()),
    ),
    sidecar=st.one_of(
        st.none(),
        st.binary(max_size=40),
        st.dictionaries(
            st.sampled_from(["wheel_radius_m", "name", "x", "contact_semi_axes_m"]),
            st.one_of(st.floats(), st.text(max_size=3), st.lists(st.floats(), max_size=3)),
            max_size=3,
        ).map(lambda d: json.dumps(d).encode()),
    ),
)
def test_garbage_never_raises_anything_but_recording_error(tmp_path_factory, data, sidecar):
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "g.csv").write_bytes(data)
    if sidecar is not None:
        (folder / "g.json").write_bytes(sidecar)
    try:
        rec = load_recording(folder / "g.csv")
    except RecordingError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(folder))
    else:
        assert all(v.dtype == np.float64 for v in rec.columns.values())


# ---------------------------------------------------------------------------------------- figure


def test_overview_figure_builds(tmp_path):
    from jadhesion.models.polach import polach_adhesion
    from jadhesion.plots.recording import recording_overview

    cols = _raw_columns(300)
    s = (cols["wheel_speed"] - cols["vehicle_speed"]) / cols["vehicle_speed"]
    cols["adhesion"] = np.asarray(polach_adhesion(DRY, s, s * cols["vehicle_speed"], LOCO_22E.k_eps()))
    save_recording(cols, LOCO_22E, tmp_path / "ov.csv")
    fig = recording_overview(load_recording(tmp_path / "ov.csv"), truth_params=DRY)
    assert len(fig.axes) == 5 and fig.axes[-1].get_xscale() == "log"
    assert fig.axes[0].get_ylabel() == "speed [km/h]"
    fig.savefig(tmp_path / "ov.png", dpi=40)
    # A creepage-only dataset with signed creep: no time, no torque, symmetric-log creep axis.
    ds = {
        "creepage": np.linspace(-0.1, 0.1, 51),
        "vehicle_speed": np.ones(51),
        "adhesion": np.linspace(-0.3, 0.3, 51),
    }
    fig = recording_overview(ds, truth_params=DRY)
    assert len(fig.axes) == 4 and fig.axes[-1].get_xscale() == "symlog"
    assert fig.axes[2].get_xlabel() == "sample [-]"
    fig.savefig(tmp_path / "ds.png", dpi=40)
