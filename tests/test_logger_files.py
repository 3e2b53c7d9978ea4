"""Recordings as loggers write them: mapped column names and units (``--column``, sidecar
``columns``) give the SI twin's values and fit; bad options give one line and exit code 2."""

import dataclasses
import json
import math
import os
import re
import subprocess
import sys
import threading
from pathlib import Path

import jax
import numpy as np
import pytest

from jadhesion.cli import main
from jadhesion.cli.recording_options import REPEATED_TIME
from jadhesion.data.dataset import to_dataset
from jadhesion.data.recording import REPEATED_TIME_POLICIES, load_recording, save_recording
from jadhesion.data.validate import _check_values
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.errors import RecordingError
from jadhesion.identify.polach_fit import fit_polach
from jadhesion.models.polach import polach_adhesion
from validation.foreign_generator import generate, write

DRY = np.array([0.4288, 1.0, 0.3555, 0.3575, 0.1316])
R = LOCO_22E.wheel_radius_m
LOGGER_MAP = [
    "time=t_ms[ms]",
    "vehicle_speed=v_Lok_kmh[km/h]",
    "wheel_speed=n_Rad[rpm]",
    "traction_torque=M_Rad_kNm[kNm]",
]
RPM_SPELLINGS = ("rpm", "1/min", "U/min", "min^-1", "min ^-1")


def _si_columns(n=400):
    """A smooth traction run in SI whose torque follows the dry Polach curve."""
    t = np.arange(n) * 0.01
    v = 0.6 + 0.2 * np.sin(0.5 * t)
    s = np.geomspace(2e-3, 0.6, n)
    mu = np.asarray(polach_adhesion(DRY, s, s * v, LOCO_22E.k_eps()))
    return {
        "time": t,
        "vehicle_speed": v,
        "wheel_speed": v * (1 + s),
        "traction_torque": mu * LOCO_22E.axle_weight_n * R,
    }


def _logger_twin(cols, path):
    """The same run as a logger writes it: German names, ms, km/h, rpm, kN·m."""
    save_recording(
        {
            "t_ms": cols["time"] * 1e3,
            "v_Lok_kmh": cols["vehicle_speed"] * 3.6,
            "n_Rad": cols["wheel_speed"] / R * 60 / (2 * math.pi),
            "M_Rad_kNm": cols["traction_torque"] / 1e3,
        },
        LOCO_22E,
        path,
    )
    return path


def test_mapped_recording_equals_its_si_twin_and_fits_the_same(tmp_path):
    cols = _si_columns()
    si = load_recording(save_recording(cols, LOCO_22E, tmp_path / "si.csv"))
    mapped = load_recording(_logger_twin(cols, tmp_path / "log.csv"), columns=LOGGER_MAP)
    assert mapped.sources == {
        "time": "t_ms[ms]",
        "vehicle_speed": "v_Lok_kmh[km/h]",
        "wheel_speed": "n_Rad[rpm]",
        "traction_torque": "M_Rad_kNm[kNm]",
    }
    for name, values in si.columns.items():
        np.testing.assert_allclose(mapped.columns[name], values, rtol=1e-14, atol=1e-15)
    fits = [fit_polach(to_dataset(r), "lm", jax.random.key(0)) for r in (si, mapped)]
    np.testing.assert_allclose(fits[1].params, fits[0].params, rtol=1e-6, atol=1e-8)


def test_sidecar_columns_map_and_flag_override(tmp_path):
    cols = _si_columns(50)
    path = _logger_twin(cols, tmp_path / "log.csv")
    sidecar = json.loads(path.with_suffix(".json").read_text())
    sidecar["columns"] = dict(spec.split("=") for spec in LOGGER_MAP)
    sidecar["columns"]["vehicle_speed"] = "v_Lok_kmh[m/s]"  # wrong in the sidecar ...
    path.with_suffix(".json").write_text(json.dumps(sidecar))
    with pytest.raises(RecordingError, match="column 'v_Lok_kmh', row 1 .*looks like km/h"):
        load_recording(path)
    rec = load_recording(path, columns=["vehicle_speed=v_Lok_kmh[km/h]"])  # ... fixed by the flag
    assert rec.notes == ()
    np.testing.assert_allclose(rec.columns["vehicle_speed"], cols["vehicle_speed"], rtol=1e-15)


BAD = {
    "bad unit": (
        ["vehicle_speed=v_Lok_kmh[furlong/s]"],
        "--column 'vehicle_speed=v_Lok_kmh[furlong/s]': unit 'furlong/s' is not a unit of vehicle_speed",
    ),
    "rpm for vehicle": (["vehicle_speed=v_Lok_kmh[rpm]"], "unit 'rpm' is not a unit of vehicle_speed"),
    "unknown column": (
        ["vehicle_speed=v_Zug"],
        "--column vehicle_speed=v_Zug: no column 'v_Zug' in the file",
    ),
    "unknown canonical": (["speed=v_Lok_kmh[km/h]"], "unknown canonical column 'speed'"),
    "no equals": (["v_Lok_kmh"], "expected CANONICAL=SOURCE[UNIT]"),
    "empty source": (["vehicle_speed=[km/h]"], "expected CANONICAL=SOURCE[UNIT]"),
    "twice": (["vehicle_speed=v_Lok_kmh[km/h]", "vehicle_speed=n_Rad"], "mapped twice"),
    "unbalanced": (["vehicle_speed=v_Lok_kmh[km/h"], "expected CANONICAL=SOURCE[UNIT]"),
    "ms as s": (
        [
            "time=t_ms",
            "vehicle_speed=v_Lok_kmh[km/h]",
            "wheel_speed=n_Rad[rpm]",
            "traction_torque=M_Rad_kNm[kNm]",
        ],
        None,
    ),  # valid: time in "seconds" still grows
    "kNm unmapped unit": (LOGGER_MAP[:3] + ["traction_torque=M_Rad_kNm"], "column 'M_Rad_kNm', row"),
    "km/h unmapped unit": (
        [
            "time=t_ms[ms]",
            "vehicle_speed=v_Lok_kmh",
            "wheel_speed=n_Rad[rpm]",
            "traction_torque=M_Rad_kNm[kNm]",
        ],
        "--column vehicle_speed=v_Lok_kmh[km/h]",
    ),
    "missing canonical": (LOGGER_MAP[:3], "missing column 'traction_torque'"),
    "torque unit on time": (["time=t_ms[kNm]"], "unit 'kNm' is not a unit of time"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_column_options_name_flag_and_column(tmp_path, case):
    path = _logger_twin(_si_columns(30), tmp_path / "log.csv")
    specs, expected = BAD[case]
    if expected is None:
        assert load_recording(path, columns=specs).n_samples == 30
        return
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=specs)
    message = str(info.value)
    assert "\n" not in message and expected in message, message


def test_cli_bad_column_exits_2_one_line_nothing_written(tmp_path):
    path = _logger_twin(_si_columns(30), tmp_path / "log.csv")
    before = set(tmp_path.iterdir())
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "jadhesion",
            "fit",
            str(path),
            "--method",
            "lm",
            "--column",
            "vehicle_speed=v_Lok_kmh[kmh]",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "JADHESION_CACHE": str(tmp_path / "cache")},
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "unit 'kmh' is not a unit of vehicle_speed" in proc.stderr
    assert set(tmp_path.iterdir()) - before <= {tmp_path / "cache"}


def test_axle_picks_one_axles_signals_and_the_map_overrides(tmp_path):
    cols = _si_columns(40)
    three = {"time": cols["time"], "vehicle_speed": cols["vehicle_speed"]}
    for n in (1, 2, 3):
        three[f"wheel_speed_{n}"] = cols["wheel_speed"] * (1 + 0.001 * n)
        three[f"traction_torque_axle{n}"] = cols["traction_torque"] * (1 + 0.01 * n)
    path = save_recording(three, LOCO_22E, tmp_path / "axles.csv")
    rec = load_recording(path, axle=2)
    np.testing.assert_array_equal(rec.columns["wheel_speed"], three["wheel_speed_2"])
    np.testing.assert_array_equal(rec.columns["traction_torque"], three["traction_torque_axle2"])
    rec = load_recording(path, axle=2, columns=["wheel_speed=wheel_speed_3"])
    np.testing.assert_array_equal(rec.columns["wheel_speed"], three["wheel_speed_3"])
    for axle, expected in [
        (4, "--axle 4: no column 'wheel_speed_4' or 'wheel_speed_axle4'"),
        (0, "--axle 0: expected an axle number >= 1"),
    ]:
        with pytest.raises(RecordingError, match=expected):
            load_recording(path, axle=axle)


def test_start_end_window_and_its_errors(tmp_path):
    from jadhesion.data.segments import trim

    rec = load_recording(_logger_twin(_si_columns(100), tmp_path / "log.csv"), columns=LOGGER_MAP)
    part = trim(rec, 0.2, 0.5)
    np.testing.assert_allclose(part.columns["time"][[0, -1]], [0.2, 0.5], atol=1e-12)
    assert part.n_samples == 31 and trim(rec) is rec
    for start, end, expected in [
        (0.5, 0.2, "--start 0.5 s is not before --end 0.2 s"),
        (5.0, None, r"select 0 sample\(s\); the recording runs from 0 s"),
        (float("nan"), None, "--start nan: expected a finite time"),
    ]:
        with pytest.raises(RecordingError, match=expected):
            trim(rec, start, end)
    # epoch time stamps: the window's ends in full, so that 1.7e9 and its end 0.99 s later differ
    epoch = dataclasses.replace(rec, columns={**rec.columns, "time": rec.columns["time"] + 1.7e9})
    with pytest.raises(
        RecordingError, match=r"runs from 1700000000 s to 1700000000\.99 s \(the bounds are times"
    ):
        trim(epoch, 10, 40)


@pytest.mark.parametrize("unit", ["kN·m", "kN.m", "kN m", "kN⋅m"])
def test_torque_unit_spellings(tmp_path, unit):
    """``kN·m`` as our own messages print it, and the other ways loggers spell a newton-metre."""
    cols = _si_columns(30)
    path = _logger_twin(cols, tmp_path / "log.csv")
    rec = load_recording(path, columns=LOGGER_MAP[:3] + [f"traction_torque=M_Rad_kNm[{unit}]"])
    np.testing.assert_allclose(rec.columns["traction_torque"], cols["traction_torque"], rtol=1e-14)


@pytest.mark.parametrize(
    ("unit", "per_second"), [("us", 1e6), ("µs", 1e6), ("μs", 1e6), ("min", 1 / 60), ("h", 1 / 3600)]
)
def test_time_units(tmp_path, unit, per_second):
    """Loggers that count microseconds, or minutes and hours: read as seconds."""
    cols = _si_columns(30)
    path = save_recording(dict(cols, time=cols["time"] * per_second), LOCO_22E, tmp_path / "log.csv")
    rec = load_recording(path, columns=[f"time=time[{unit}]"])
    np.testing.assert_allclose(rec.columns["time"], cols["time"], rtol=1e-12, atol=1e-12)


def _renamed(cols, names, path, **extra):
    """``cols`` (SI) saved under ``names`` (canonical -> header), each in its header's unit."""
    rpm = 60 / (2 * math.pi * R)
    scale = {"ms": 1e3, "km/h": 3.6, "kNm": 1e-3, "kN·m": 1e-3} | dict.fromkeys(RPM_SPELLINGS, rpm)
    out = {h: cols[c] * scale.get(h.rpartition("[")[2].rstrip("]"), 1.0) for c, h in names.items()}
    return save_recording(out | extra, LOCO_22E, path)


def _assert_si(rec, cols):
    for name, values in cols.items():
        np.testing.assert_allclose(rec.columns[name], values, rtol=1e-14, atol=1e-15)


def _message(path, columns=()):
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=columns)
    assert "\n" not in str(info.value)
    return str(info.value)


def test_units_in_parentheses(tmp_path):
    """``SOURCE (UNIT)`` headers with a listed unit, named in full or by SOURCE, are read in their
    unit (``Vehicle speed (km/h)`` named in full was read as m/s: μ0 0.384 against 0.415); a unit of
    another column is refused; ``Speed (front)`` stays a name."""
    cols = _si_columns(30)
    rpm = 60 / (2 * math.pi * R)
    logged = {
        "Time (ms)": cols["time"] * 1e3,
        "Vehicle speed (km/h)": cols["vehicle_speed"] * 3.6,
        "Wheel speed (rpm)": cols["wheel_speed"] * rpm,
        "Torque (kN·m)": cols["traction_torque"] / 1e3,
        "Odd (km/h)": cols["traction_torque"],
        "Speed (front)": cols["traction_torque"],
    }
    path = save_recording(logged, LOCO_22E, tmp_path / "paren.csv")
    full = ["time=Time (ms)", "vehicle_speed=Vehicle speed (km/h)", "wheel_speed=Wheel speed (rpm)"]
    _assert_si(load_recording(path, columns=[*full, "traction_torque=Torque (kN·m)"]), cols)
    short = ["time=Time", "vehicle_speed=Vehicle speed", "wheel_speed=Wheel speed", "traction_torque=Torque"]
    _assert_si(load_recording(path, columns=short), cols)
    assert "the header states 'km/h', not a unit of traction_torque" in _message(
        path, [*full, "traction_torque=Odd (km/h)"]
    )
    named = load_recording(path, columns=[*full, "traction_torque=Speed (front)"])
    np.testing.assert_allclose(named.columns["traction_torque"], cols["traction_torque"], rtol=1e-14)


def test_units_in_headers(tmp_path):
    """``SOURCE[UNIT]`` or ``SOURCE [UNIT]`` headers: ``--column`` names SOURCE (with the unit, or
    leaves it to the header's); a canonical header with its unit is read in that unit unmapped."""
    cols = _si_columns(30)
    names = ["t [ms]", "v_Lok[km/h]", "n_Rad [1/min]", "M_Rad [kNm]"]
    path = _renamed(cols, dict(zip(cols, names, strict=True)), tmp_path / "log.csv")
    mapped = [
        "time=t[ms]",
        "vehicle_speed=v_Lok[km/h]",
        "wheel_speed=n_Rad[rpm]",
        "traction_torque=M_Rad[kN·m]",
    ]
    _assert_si(load_recording(path, columns=mapped), cols)
    rec = load_recording(
        path, columns=["time=t", "vehicle_speed=v_Lok", "wheel_speed=n_Rad[rpm]", "traction_torque=M_Rad"]
    )
    _assert_si(rec, cols)
    assert list(rec.sources.values()) == ["t[ms]", "v_Lok[km/h]", "n_Rad[rpm]", "M_Rad[kNm]"]
    assert _message(path, ["vehicle_speed=v_Lok[m/s]"]).endswith(
        "--column vehicle_speed=v_Lok[m/s]: no column 'v_Lok' in the file (columns: "
        "t [ms], v_Lok[km/h], n_Rad [1/min], M_Rad [kNm]); column 'v_Lok[km/h]' is in km/h, not m/s"
    )

    names = ["time [ms]", "vehicle_speed[km/h]", "wheel_speed [rpm]", "traction_torque [kN·m]"]
    rec = load_recording(
        _renamed(
            cols, dict(zip(cols, names, strict=True)), tmp_path / "own.csv", **{"creepage [%]": cols["time"]}
        )
    )
    _assert_si(rec, cols)
    assert list(rec.sources.values()) == [
        "time[ms]",
        "vehicle_speed[km/h]",
        "wheel_speed[rpm]",
        "traction_torque[kN*m]",
    ]
    assert any("column 'creepage [%]': '%' is not a unit of creepage" in n for n in rec.notes)

    twice = _renamed(
        cols, {"time": "t", "vehicle_speed": "v[km/h]"}, tmp_path / "twice.csv", **{"v [km/h]": cols["time"]}
    )
    assert _message(twice, ["vehicle_speed=v[km/h]"]).endswith(
        "twice.csv: --column vehicle_speed=v[km/h]: columns 'v[km/h]' and 'v [km/h]' both match; rename one"
    )


@pytest.mark.parametrize("unit", RPM_SPELLINGS[1:])
def test_german_rpm_spellings(tmp_path, unit):
    """``1/min``, ``U/min``, ``min^-1`` (German loggers' rpm) in a header or a ``--column``: read
    as rpm, and one unit with it; a header in a unit not of wheel_speed still says so."""
    cols = _si_columns(30)
    names = ["t [ms]", "v_Lok [km/h]", f"n_Rad [{unit}]", "M_Rad [kNm]"]
    path = _renamed(
        cols, dict(zip(cols, names, strict=True)), tmp_path / "log.csv", **{"n_Mot [Hz]": cols["time"]}
    )
    for wheel in ("n_Rad", "n_Rad[rpm]", f"n_Rad[{unit}]"):
        columns = ["time=t", "vehicle_speed=v_Lok", f"wheel_speed={wheel}", "traction_torque=M_Rad"]
        _assert_si(load_recording(path, columns=columns), cols)
    assert _message(path, ["wheel_speed=n_Mot"]).endswith(
        "column 'n_Mot [Hz]': 'Hz' is not a unit of wheel_speed; give its unit, "
        "--column wheel_speed=n_Mot[UNIT]"
    )


def test_canonical_names_ignore_case(tmp_path):
    cols = _si_columns(30)
    names = {c: c.title() for c in cols}
    rec = load_recording(_renamed(cols, names, tmp_path / "upper.csv"))
    _assert_si(rec, cols)
    assert rec.sources == names and rec.notes == ()
    message = _message(_renamed(cols, names, tmp_path / "two.csv", TIME=cols["time"]))
    assert "missing column 'time'" in message and message.endswith(
        "; columns 'Time' and 'TIME' both match 'time' ignoring case and unit: "
        "map one with --column time=SOURCE"
    )


def test_units_row_under_the_header(tmp_path):
    """A second line of units (an empty cell: no unit) reads as each header's ``[unit]``; a
    --column unit given where the row has none applies, one against it is one error line; a row
    that is not all units stays 'not a number'."""
    cols = _si_columns(30)
    twin = _logger_twin(cols, tmp_path / "twin.csv").read_text().splitlines()
    names = "time,v [km/h],n,M"
    path = tmp_path / "units.csv"
    path.write_text("\n".join([names, "ms, km/h ,1/min,", *twin[1:]]) + "\n")
    mapped = ["vehicle_speed=v", "wheel_speed=n", "traction_torque=M[kN·m]"]
    rec = load_recording(path, columns=mapped)
    _assert_si(rec, cols)
    assert rec.sources == {
        "vehicle_speed": "v[km/h]",
        "wheel_speed": "n[1/min]",
        "traction_torque": "M[kN*m]",
        "time": "time[ms]",
    }
    assert _message(path, [*mapped, "time=time[s]"]).endswith("column 'time [ms]' is in ms, not s")
    path.write_text("\n".join([names, "ms,km/h,rpm,", "0,x,0,0", *twin[2:]]) + "\n")
    assert _message(path, mapped) == f"{path}: column 'v [km/h]', row 1 (line 3): 'x' is not a number"
    path.write_text("\n".join([names, "ms,m/s,rpm,kNm", *twin[1:]]) + "\n")
    assert (
        _message(path) == f"{path}: column 'v [km/h]', units row (line 2): 'm/s', but the header says 'km/h'"
    )
    path.write_text("\n".join([names, "ms,km/h,rpm,furlong", *twin[1:]]) + "\n")
    assert _message(path, mapped) == f"{path}: column 'time', row 1 (line 2): 'ms' is not a number"
    path.write_text("time,vehicle_speed\ns,m/s\n")
    assert _message(path) == f"{path}: no data rows after the units row (line 2)"


def test_a_row_of_dashes_is_missing_values_not_units(tmp_path):
    """``-`` is the unit of a dimensionless column, but a row of nothing else under the header is
    a row of missing values: named as such, not read as units (which made every column's unit
    '-' and the file a list of unit errors)."""
    twin = _logger_twin(_si_columns(30), tmp_path / "twin.csv").read_text().splitlines()
    path = tmp_path / "dashes.csv"
    path.write_text("\n".join([twin[0], ",".join("-" * len(twin[0].split(","))), *twin[1:]]) + "\n")
    assert _message(path, LOGGER_MAP) == (
        f"{path}: column 't_ms', row 1 (line 2): '-' is not a number "
        "(a missing value; --missing skip leaves such rows out (gaps in time))"
    )


def _quoted(lines, decimal=","):
    return [",".join(f'"{c}"'.replace(".", decimal) for c in line.split(",")) for line in lines]


def test_quoted_decimal_commas_in_a_comma_separated_file(tmp_path):
    """A spreadsheet that writes decimal commas but separates fields by commas quotes every
    number (``"0,489"``): read value for value as its twin with points, with a note. When every
    such number could also be a thousands group (``"1,500"``), the first is one error line."""
    cols = _si_columns(30)
    twin_path = _logger_twin(cols, tmp_path / "twin.csv")
    twin = twin_path.read_text().splitlines()
    path = tmp_path / "quoted.csv"
    path.write_text("\n".join([twin[0], *_quoted(twin[1:])]) + "\n")
    rec, ref = load_recording(path, columns=LOGGER_MAP), load_recording(twin_path, columns=LOGGER_MAP)
    for k, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[k], v)
    assert f"{path}: quoted numbers with decimal commas read with decimal points" in rec.notes
    header = "time,vehicle_speed,wheel_speed,traction_torque\n"
    path.write_text(header + '"1,500","2,000","2,000","3,000"\n' * 3)
    assert _message(path) == (
        f"{path}: row 1 (line 2), column 1: '1,500' is a decimal comma or a thousands separator; "
        "write the numbers with a decimal point"
    )


def test_inspect_text_tells_epoch_times_apart(tmp_path, capsys):
    """Times since 1970 (1.7e9 s) at 100 Hz: the text's gap and excluded-stretch bounds are the
    JSON's to the step, not all '1.7e+09'."""
    cols = _si_columns(400)
    cols["time"] = cols["time"] + 1.7e9 + 5.0 * (np.arange(400) >= 200)
    cols["vehicle_speed"][:40] = cols["wheel_speed"][:40] = 0.0
    path = save_recording(cols, LOCO_22E, tmp_path / "epoch.csv")
    assert main(["inspect", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert main(["inspect", str(path)]) == 0
    text = capsys.readouterr().out
    shown = [[float(x) for x in m] for m in re.findall(r"([-\d.e+]+) s → ([-\d.e+]+) s", text)]
    shown += [[float(x) for x in m] for m in re.findall(r"excluded .*: ([-\d.e+]+)–([-\d.e+]+) s", text)]
    expected = doc["sampling"]["gaps"] + [[e["start"], e["end"]] for e in doc["selection"]["excluded"]]
    assert len(expected) == 2 and doc["selection"]["excluded"][0]["end"] == pytest.approx(1.7e9 + 0.39)
    np.testing.assert_allclose(shown, expected, rtol=0, atol=0.005)


def test_time_in_ms_labelled_seconds_is_noted_not_refused(tmp_path):
    """Whole steps of 1 s or more over more than 10 000 s: likely ms, a note naming the fix, not an
    error; whole 3 s steps over 3297 s, fractional steps or a 100 Hz run get none."""
    cols = _si_columns(1100)
    ms = np.round(cols["time"] * 1e3)
    rec = load_recording(save_recording(dict(cols, time=ms), LOCO_22E, tmp_path / "ms.csv"))

    def notes(time):
        shown = {"time": "t"}
        return _check_values({**rec.columns, "time": time}, LOCO_22E, None, "ms.csv", 70.0, shown)

    assert any("looks like ms?" in n for n in rec.notes)  # load_recording keeps the note
    assert notes(rec.columns["time"]) == (
        "ms.csv: column 't': median time step 10 s over 1.099e+04 s, every step a whole number "
        'of seconds; looks like ms? map it with --column time=t[ms] (or the sidecar\'s "columns")',
    )
    assert (
        notes(np.arange(1100) * 3.0) == notes(ms + 0.5 * (np.arange(1100) % 2)) == notes(cols["time"]) == ()
    )


def test_a_time_column_in_minutes_or_hours_labelled_seconds_is_refused(tmp_path):
    """A start in minutes read as seconds accelerates at 60× its rate (a 30 s start to 3 m/s:
    6 m/s², beyond any train's 5): refused naming the unit, where it fitted a "converged" mu_max
    0.135 for 0.348 before. Hours, and times multiplied by 1e60 (a traceback in the trust block
    before), have median steps beyond an hour: refused. Mapped with its unit, the file reads."""
    start = generate(0, effect="none", sensor="realistic", rate_hz=50.0, profile="start", duration_s=30.0)
    path = write(start, tmp_path / "s.csv")
    lines = path.read_text().splitlines()

    def rescaled(name, factor):
        out = path.with_name(name)
        rows = [line.split(",") for line in lines[1:]]
        out.write_text("\n".join([lines[0], *(",".join([repr(float(r[0]) * factor), *r[1:]]) for r in rows)]))
        out.with_suffix(".json").write_text(path.with_suffix(".json").read_text())
        return out

    minutes = rescaled("min.csv", 1 / 60)
    with pytest.raises(RecordingError, match=r"m/s², beyond any train's 5\): is the time in another unit\? "
                       r"map it with --column time=time\[min\]"):  # fmt: skip
        load_recording(minutes)
    read = load_recording(minutes, columns=("time=time[min]",))
    np.testing.assert_allclose(read.columns["time"], load_recording(path).columns["time"], rtol=1e-12)
    for name, factor in (("h.csv", 1 / 3600), ("big.csv", 1e60)):
        with pytest.raises(RecordingError, match="is the time in another unit|more than an hour"):
            load_recording(rescaled(name, factor))


@pytest.mark.skipif(not os.path.exists("/dev/zero") or not hasattr(os, "mkfifo"), reason="POSIX devices")
def test_streams_are_read_and_an_endless_one_is_refused(tmp_path):
    """A pipe (``/dev/stdin``, a FIFO) reads as its file does; ``/dev/zero`` is one error line after
    one chunk (it had filled the machine's memory until the kernel killed the process)."""
    twin = _logger_twin(_si_columns(30), tmp_path / "twin.csv")
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_bytes, args=(twin.read_bytes(),))
    writer.start()
    rec = load_recording(fifo, columns=LOGGER_MAP)
    writer.join()
    same = load_recording(twin, columns=LOGGER_MAP)
    np.testing.assert_array_equal(rec.columns["time"], same.columns["time"])
    assert _message(Path("/dev/zero")) == "/dev/zero: binary data (NUL byte at byte 0), not a text file"


def test_repeated_time_stamps_are_named_or_dropped_on_request(tmp_path, capsys):
    """A logger that writes a row twice, or stamps coarser than its rate, repeats a time stamp:
    by default one line naming the row and the option; with ``--repeated-time drop`` the first row
    of each stamp is kept, the rest read exactly as the twin without those rows, and a note counts
    them and how many differ from the row kept. A time that goes back stays an error either way;
    ``inspect`` takes the option end to end."""
    cols = _si_columns(60)
    twin = _logger_twin(cols, tmp_path / "twin.csv").read_text().splitlines()
    head, rows = twin[0], twin[1:]
    coarse = rows[30].split(",")
    coarse[1:] = rows[31].split(",")[1:]  # row 31's values under row 30's stamp: a coarse stamp
    path = tmp_path / "repeats.csv"
    path.write_text("\n".join([head, *rows[:10], rows[9], *rows[10:31], ",".join(coarse), *rows[32:]]) + "\n")
    assert _message(path, LOGGER_MAP) == (
        f"{path}: column 't_ms', row 11 (line 12): time 0.09 s is not after the previous row's 0.09 s "
        "(time must strictly increase; --repeated-time drop keeps the first row of each repeated stamp)"
    )
    rec = load_recording(path, columns=LOGGER_MAP, repeated_time="drop")
    ref = load_recording(tmp_path / "twin.csv", columns=LOGGER_MAP)
    kept = np.setdiff1d(np.arange(60), [31])  # row 31's values sat under a repeated stamp
    for c, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[c], v[kept])
    (note,) = [n for n in rec.notes if "repeating" in n]
    assert note == (
        f"{path}: 2 of 61 rows dropped for repeating the previous row's time stamp in column 't_ms' "
        "(--repeated-time drop; the first at row 11 (line 12); 1 differs from the row kept)"
    )
    back = tmp_path / "back.csv"
    back.write_text("\n".join([head, *rows[:10], rows[5], *rows[10:]]) + "\n")
    with pytest.raises(RecordingError, match=r"row 11 \(line 12\): time 0.05 s .* strictly increase\)$"):
        load_recording(back, columns=LOGGER_MAP, repeated_time="drop")
    with pytest.raises(ValueError, match="repeated_time must be one of"):
        load_recording(path, repeated_time="skip")
    assert REPEATED_TIME == REPEATED_TIME_POLICIES  # the command line offers what the reader knows
    mapped = [a for c in LOGGER_MAP for a in ("--column", c)]
    assert main(["inspect", str(path), *mapped, "--json"]) == 2
    assert main(["inspect", str(path), *mapped, "--repeated-time", "drop", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["samples"] == 59 and any("2 of 61 rows dropped" in n for n in doc["notes"])


def test_fit_says_the_readers_notes(tmp_path, capsys):
    """Time stamps in ms written without a unit (12 000 s in 10 s steps): ``fit`` says inspect's
    "looks like ms?" note on stderr and in its JSON's ``notes`` (it fitted on in silence)."""
    cols = _si_columns(1200)
    cols["time"] = cols["time"] * 1e3
    path = save_recording(cols, LOCO_22E, tmp_path / "ms.csv")
    assert main(["fit", str(path), "--method", "lm", "--single-law", "--json"]) == 0
    captured = capsys.readouterr()
    notes = json.loads(captured.out)["notes"]
    assert len(notes) == 1 and "looks like ms? map it with --column time=time[ms]" in notes[0]
    assert f"jadhesion: note: {notes[0]}\n" in captured.err
    # online's and posterior's JSON hold them too (they said them on stderr alone)
    assert main(["online", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == notes
    assert main(["posterior", str(path), "--steps", "60", "--walkers", "12", "--single-law", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == notes
