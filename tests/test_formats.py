"""Parquet and MATLAB .mat (v5, v7.3) recordings: the same column map, validation and dataset as the
CSV; missing optional packages and bad files give one line naming the file, column and row."""

import builtins
import json

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy.io
from logger_data import LOGGER_MAP, logger_columns, stretches_si, write_logger_file

from jadhesion.cli import main
from jadhesion.cli.fit_run import expand_files
from jadhesion.data.dataset import to_dataset
from jadhesion.data.formats import read_columns
from jadhesion.data.readers import normalise_delimiter
from jadhesion.data.recording import load_recording
from jadhesion.errors import RecordingError


def _sidecar(csv, target):
    target.with_suffix(".json").write_text(csv.with_suffix(".json").read_text())
    return target


def write_parquet(cols, path):
    pq.write_table(pa.table({**cols, "driver": ["A"] * len(cols["t_ms"])}), path)
    return path


def write_mat5(cols, path):
    scipy.io.savemat(path, {**{k: v.reshape(-1, 1) for k, v in cols.items()}, "rate_hz": 100.0})
    return path


def write_mat73(cols, path):
    with h5py.File(path, "w") as f:  # MATLAB v7.3 stores an n×1 vector as a 1×n dataset
        for k, v in cols.items():
            f.create_dataset(k, data=v.reshape(1, -1))
        f.create_dataset("rate_hz", data=np.array([[100.0]]))
    return path


WRITERS = {
    "parquet": (write_parquet, ".parquet"),
    "mat5": (write_mat5, ".mat"),
    "mat73": (write_mat73, ".mat"),
}


@pytest.fixture(scope="module")
def csv(tmp_path_factory):
    return write_logger_file(tmp_path_factory.mktemp("fmt") / "log.csv")


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_round_trip_gives_the_csv_dataset(csv, tmp_path, fmt):
    writer, suffix = WRITERS[fmt]
    path = _sidecar(csv, writer(logger_columns(stretches_si()), tmp_path / f"log{suffix}"))
    rec, ref = load_recording(path), load_recording(csv)
    assert rec.sources == ref.sources and set(rec.columns) == set(ref.columns)
    for k, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[k], v)
    if fmt != "parquet":
        assert any("'rate_hz' ignored" in n for n in rec.notes)
    else:
        assert any("'driver' ignored" in n for n in rec.notes)
    for a, b in zip(to_dataset(rec, creep="raw"), to_dataset(ref, creep="raw"), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("fmt", ["mat5", "mat73"])
def test_mat_struct_reads_as_its_fields(csv, tmp_path, fmt):
    """A MATLAB logger often saves one struct (``Messung.t_ms``, …; v7.3: a group): its fields
    are the columns, by their own names; a name two fields share is dotted in full."""
    cols = logger_columns(stretches_si())
    path = _sidecar(csv, tmp_path / "struct.mat")
    if fmt == "mat5":
        scipy.io.savemat(
            path, {"Messung": {**{k: v.reshape(-1, 1) for k, v in cols.items()}, "info": {"rate_hz": 100.0}}}
        )
    else:
        with h5py.File(path, "w") as f:
            group = f.create_group("Messung")
            for k, v in cols.items():
                group.create_dataset(k, data=v.reshape(1, -1))
            f.create_dataset("t_ms", data=cols["t_ms"].reshape(1, -1))
    rec, ref = load_recording(path), load_recording(csv)
    for k, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[k], v)
    if fmt == "mat73":  # two 't_ms': the field is dotted in full, the variable keeps its name
        mapped = load_recording(path, columns=["time=Messung.t_ms[ms]"])
        assert rec.sources["time"] == "t_ms[ms]" and mapped.sources["time"] == "Messung.t_ms[ms]"
        np.testing.assert_array_equal(mapped.columns["time"], ref.columns["time"])


def test_cli_inspect_reads_parquet_with_column_flags(csv, tmp_path, capsys):
    path = write_parquet(logger_columns(stretches_si()), tmp_path / "log.parquet")  # no sidecar
    argv = ["inspect", str(path), "--json"] + [x for c in LOGGER_MAP for x in ("--column", c)]
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["selection"]["used"] == 700


def test_bad_values_name_file_column_row(tmp_path):
    cols = logger_columns(stretches_si())
    cols["v_Lok_kmh"] = cols["v_Lok_kmh"].copy()
    cols["v_Lok_kmh"][16] = np.nan
    path = write_parquet(cols, tmp_path / "nan.parquet")
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=LOGGER_MAP)
    assert str(info.value) == (
        f"{path}: column 'v_Lok_kmh', row 17: nan is not a finite number "
        f"(NaN, a missing value, and inf are not allowed; --missing skip leaves such rows out (gaps in time))"
    )
    skipped = load_recording(path, columns=LOGGER_MAP, missing="skip")  # the row left out, as in a CSV
    assert len(skipped.columns["time"]) == len(cols["t_ms"]) - 1
    assert any("1 of" in n and "row 17, column 'v_Lok_kmh'" in n for n in skipped.notes), skipped.notes
    cols = logger_columns(stretches_si())
    path = write_mat5(cols, tmp_path / "kmh.mat")
    with pytest.raises(
        RecordingError,
        match=r"kmh.mat: column 'v_Lok_kmh', row 101: median "
        r".* --column vehicle_speed=v_Lok_kmh\[km/h\]$",
    ):
        load_recording(
            path,
            columns=[
                "time=t_ms[ms]",
                "vehicle_speed=v_Lok_kmh",
                "wheel_speed=n_Rad[rpm]",
                "traction_torque=M_Rad_kNm[kNm]",
            ],
        )
    text = tmp_path / "text.parquet"
    pq.write_table(
        pa.table(
            {
                "time": ["a", "b"],
                "vehicle_speed": [1.0, 1.0],
                "wheel_speed": [1.0, 1.0],
                "traction_torque": [1.0, 1.0],
            }
        ),
        text,
    )
    with pytest.raises(RecordingError, match="text.parquet: column 'time': not numeric"):
        load_recording(text)
    junk = tmp_path / "junk.mat"
    junk.write_bytes(b"not a mat file at all" * 10)
    with pytest.raises(RecordingError, match="junk.mat: not a readable MATLAB .mat file"):
        load_recording(junk)
    with pytest.raises(RecordingError, match="junk.parquet: not a readable Parquet file"):
        load_recording(junk.rename(tmp_path / "junk.parquet"))


@pytest.mark.parametrize("fmt,module,extra", [("parquet", "pyarrow", "parquet"), ("mat5", "scipy", "mat")])
def test_missing_optional_package_is_one_line(tmp_path, monkeypatch, fmt, module, extra):
    writer, suffix = WRITERS[fmt]
    path = writer(logger_columns(stretches_si()), tmp_path / f"log{suffix}")
    real_import = builtins.__import__

    def no_module(name, *args, **kwargs):
        if name == module or name.startswith(module + "."):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_module)
    if fmt == "mat5":
        monkeypatch.setattr(h5py, "is_hdf5", lambda p: False)
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=LOGGER_MAP)
    assert str(info.value).endswith(f"install jadhesion[{extra}]") and str(path) in str(info.value)


def test_cli_bad_input_exits_2_one_line_nothing_written(tmp_path, capsys):
    path = write_parquet(logger_columns(stretches_si()), tmp_path / "log.parquet")
    before = set(tmp_path.iterdir())
    for extra, expected in [
        (["--column", "vehicle_speed=nope"], "no column 'nope' in the file"),
        (LOGGER_MAP[:3], "missing column 'traction_torque'"),
    ]:
        argv = ["inspect", str(path), "--json", "--plot", str(tmp_path / "plots")]
        argv += [x for c in extra for x in ("--column", c)] if extra[0] != "--column" else extra
        assert main(argv) == 2
        out, err = capsys.readouterr()
        assert out == "" and err.count("\n") == 1 and expected in err and str(path) in err
    assert set(tmp_path.iterdir()) == before


@pytest.mark.parametrize("style", ["semicolon", "tab", "tab-decimal-comma"])
def test_european_and_tab_separated_text_reads_as_its_comma_twin(csv, tmp_path, style):
    """A spreadsheet in a European locale writes ``;`` between fields and decimal commas; some
    loggers write tabs, with decimal points or commas. Each reads as the comma-separated file,
    value for value, with a note; a bad cell still names its line."""
    text = csv.read_text()
    if style == "semicolon":
        text = text.replace(",", ";").replace(".", ",")
    else:
        text = text.replace(",", "\t")
    if style == "tab-decimal-comma":
        text = text.replace(".", ",")
    path = _sidecar(csv, tmp_path / f"{style}.csv")
    path.write_text(text)
    rec, ref = load_recording(path), load_recording(csv)
    for k, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[k], v)
    assert any(f"{style.split('-')[0]}-separated" in n for n in rec.notes)
    assert any("commas as decimal points" in n for n in rec.notes) == (style != "tab")
    lines = text.splitlines()
    lines[40] = lines[40].replace(
        ";" if style == "semicolon" else "\t", ";fast" if style == "semicolon" else "\tfast", 1
    )
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match="line 41"):
        load_recording(path)


def test_semicolon_text_with_thousands_points_reads_as_its_comma_twin(tmp_path):
    """A German spreadsheet writes 25472.08 as ``25.472,08``: its points between digit groups are
    thousands separators (``1.500`` there is 1500), not a cell '25.472.08' that is not a number."""
    cols = {"time": [0.0, 0.01, 0.02], "vehicle_speed": [1.5, 1.51, 1.52], "wheel_speed": [1.52, 1.53, 1.54]}
    torque = [25472.08, 1500.0, 31234.5]
    de = {25472.08: "25.472,08", 1500.0: "1.500", 31234.5: "31.234,5"}
    rows = ["time;vehicle_speed;wheel_speed;traction_torque"] + [
        ";".join([*(f"{cols[k][i]:g}".replace(".", ",") for k in cols), de[torque[i]]]) for i in range(3)
    ]
    path = tmp_path / "de.csv"
    path.write_text("\n".join(rows) + "\n")
    text, notes = normalise_delimiter(path.read_text())
    assert text.splitlines()[1:] == ["0,1.5,1.52,25472.08", "0.01,1.51,1.53,1500", "0.02,1.52,1.54,31234.5"]
    assert notes == (
        "read as semicolon-separated, commas as decimal points, points between digit groups as "
        "thousands separators",
    )
    np.testing.assert_array_equal(load_recording(path).columns["traction_torque"], torque)


@pytest.mark.parametrize("case", ["empty", "text", "truncated_v73"])
def test_unreadable_mat_is_one_line_naming_the_file(tmp_path, capsys, case):
    path = tmp_path / f"{case}.mat"
    if case == "truncated_v73":
        pytest.importorskip("h5py")
        whole = write_mat73(logger_columns(stretches_si()), tmp_path / "whole.mat").read_bytes()
        path.write_bytes(whole[: len(whole) // 2])
    else:
        path.write_bytes(b"" if case == "empty" else b"hello, world!\n")
    assert main(["inspect", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert f"{path}: not a readable MATLAB .mat file (" in err


@pytest.mark.parametrize("style", ["comma", "semicolon"])
def test_trailing_delimiter_is_dropped_an_empty_named_column_with_data_is_not(csv, tmp_path, style):
    """Excel and SAP end every line with a delimiter: an unnamed last column without a value in
    any row is no column; one with a value keeps the error."""
    lines = csv.read_text().splitlines()
    if style == "semicolon":
        lines = [line.replace(",", ";").replace(".", ",") for line in lines]
    sep = ";" if style == "semicolon" else ","
    path = _sidecar(csv, tmp_path / f"{style}.csv")
    path.write_text("".join(f"{line}{sep}\n" for line in lines))
    rec, ref = load_recording(path), load_recording(csv)
    assert set(rec.columns) == set(ref.columns)
    for k, v in ref.columns.items():
        np.testing.assert_array_equal(rec.columns[k], v)
    lines = [f"{line}{sep}" for line in lines]
    lines[7] += "1"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        RecordingError, match=rf"header \(line 1\): column {len(lines[0].split(sep))} has an empty name"
    ):
        load_recording(path)


@pytest.mark.parametrize("kind", ["timestamp", "duration"])
def test_parquet_time_as_timestamp_or_duration_reads_as_seconds(tmp_path, kind):
    """A pandas or Spark export stores time as a timestamp (epoch seconds, float64) or a duration."""
    cols = stretches_si()
    ticks = np.round(cols["time"] * 1e6).astype(np.int64)  # µs
    epoch = 1_700_000_000 * 1_000_000 if kind == "timestamp" else 0
    unit = pa.timestamp("us", tz="UTC") if kind == "timestamp" else pa.duration("us")
    path = tmp_path / f"{kind}.parquet"
    pq.write_table(pa.table({**cols, "time": pa.array(ticks + epoch, unit)}), path)
    time = load_recording(path).columns["time"]
    assert time.dtype == np.float64
    np.testing.assert_allclose(time - epoch / 1e6, cols["time"], atol=1e-6)


@pytest.mark.parametrize("tz", [None, "UTC"])
def test_parquet_ns_timestamps_read_as_epoch_seconds_as_an_iso_csv(tmp_path, capsys, tz):
    """pandas writes ``datetime64[ns]`` (naive or zone-aware): beyond 2**53 ticks, read as float64
    seconds since the epoch like a CSV's ISO date-times, steps exact to float64's resolution; a
    null is a missing value named by its row."""
    cols = stretches_si()
    epoch = 1_777_593_600  # 2026-05-01 UTC [s]
    ticks = np.round(cols["time"] * 1e9).astype(np.int64) + epoch * 10**9
    path = tmp_path / "ns.parquet"
    pq.write_table(pa.table({**cols, "time": pa.array(ticks, pa.timestamp("ns", tz=tz))}), path)
    time = load_recording(path).columns["time"]
    assert time.dtype == np.float64 and time[0] == epoch
    ulp = np.spacing(float(epoch))  # ~2.4e-7 s
    np.testing.assert_allclose(np.diff(time), np.diff(cols["time"]), rtol=0, atol=ulp)
    csv = tmp_path / "iso.csv"
    stamps = np.datetime_as_string(ticks.astype("datetime64[ns]"), unit="us")
    csv.write_text(
        "time,vehicle_speed,wheel_speed,traction_torque\n"
        + "".join(
            f"{t},{v},{w},{m}\n"
            for t, v, w, m in zip(stamps, *(cols[k] for k in list(cols)[1:]), strict=True)
        )
    )
    np.testing.assert_array_equal(time, load_recording(csv).columns["time"])
    assert main(["fit", str(path), "--method", "lm", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)
    nulls = pa.array(ticks, pa.timestamp("ns", tz=tz), mask=np.arange(ticks.size) == 16)
    pq.write_table(pa.table({**cols, "time": nulls}), path)
    with pytest.raises(RecordingError, match=r"ns.parquet: column 'time', row 17: nan is not a finite"):
        load_recording(path)


def test_parquet_int64_beyond_2_53_reads(tmp_path):
    """An int64 column past float64's exact integers (a ns epoch counter) reads, rounded to float64."""
    cols = stretches_si()
    t_ns = np.round(cols["time"] * 1e9).astype(np.int64) + 1_777_593_600 * 10**9
    path = tmp_path / "int.parquet"
    pq.write_table(pa.table({**cols, "t_ns": t_ns}), path)
    np.testing.assert_array_equal(load_recording(path).columns["t_ns"], t_ns.astype(np.float64))
    # mapped as the time in ns: epoch seconds, each to float64's rounding of the ns (0.26 µs)
    pq.write_table(pa.table({k: v for k, v in cols.items() if k != "time"} | {"t_ns": t_ns}), path)
    time = load_recording(path, columns=["time=t_ns[ns]"]).columns["time"]
    np.testing.assert_allclose(time, cols["time"] + 1_777_593_600, rtol=0, atol=5e-7)


def test_directory_lists_every_text_suffix(csv, tmp_path):
    """A directory stands for every file a recording can be: text (.csv, .tsv, .txt), Parquet, .mat."""
    text = csv.read_text()
    for name, body in [
        ("a.csv", text),
        ("b.TSV", text.replace(",", "\t")),
        ("c.txt", text),
        ("d.json", "{}"),
    ]:
        (tmp_path / name).write_text(body)
    write_parquet(logger_columns(stretches_si()), tmp_path / "e.parquet")
    (tmp_path / "f.png").write_bytes(b"\x89PNG")
    paths, many = expand_files([str(tmp_path)])
    assert [p.name for p in paths] == ["a.csv", "b.TSV", "c.txt", "e.parquet"] and many
    ref = load_recording(tmp_path / "a.csv", columns=LOGGER_MAP).columns["time"]
    for p in paths[1:3]:
        np.testing.assert_array_equal(load_recording(p, columns=LOGGER_MAP).columns["time"], ref)


@pytest.mark.parametrize("fmt", ["mat5", "mat73"])
def test_complex_mat_variable_is_named_not_dropped(tmp_path, fmt):
    """A complex vector is a column that is not numeric, named so (not 'missing column'); an
    unused one is left out with a note saying it is complex."""
    writer, _ = WRITERS[fmt]
    cols = logger_columns(stretches_si())
    v = cols["v_Lok_kmh"]
    if fmt == "mat5":
        cols["v_Lok_kmh"] = v + 0j
    else:
        cols["v_Lok_kmh"] = np.rec.fromarrays([v, 0 * v], names="real,imag")
    path = writer(cols, tmp_path / f"complex_{fmt}.mat")
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=LOGGER_MAP)
    assert str(info.value).startswith(f"{path}: column 'v_Lok_kmh': not numeric")
    cols["v_Lok_kmh"], cols["phase"] = v, cols["v_Lok_kmh"]
    rec = load_recording(writer(cols, tmp_path / f"unused_{fmt}.mat"), columns=LOGGER_MAP)
    assert "phase" not in rec.columns
    assert any("variable 'phase' complex, not read (a signal must be real)" in n for n in rec.notes)


def _short_and_complex_mat(tmp_path, case):
    """A raw-signal .mat of 1200 samples whose ``wheel_speed`` has 10 fewer or whose
    ``traction_torque`` is complex."""
    cols = {k: v.reshape(-1, 1) for k, v in stretches_si().items()}
    if case == "short":
        cols["wheel_speed"] = cols["wheel_speed"][:-10]
    else:
        cols["traction_torque"] = cols["traction_torque"] * (1 + 1j)
    path = tmp_path / f"{case}.mat"
    scipy.io.savemat(path, cols)
    return path


def test_mat_vector_of_another_length_is_noted_with_both_lengths(tmp_path):
    path = _short_and_complex_mat(tmp_path, "short")
    header, _, notes = read_columns(path, str(path))
    assert header == ["time", "vehicle_speed", "traction_torque"]
    assert notes == (f"{path}: variable 'wheel_speed' has 1190 values, the others 1200: ignored",)


@pytest.mark.parametrize(
    "case,expected",
    [
        ("short", "variable 'wheel_speed' has 1190 values, the others 1200"),
        ("complex", "variable 'traction_torque' complex"),
    ],
)
def test_mat_error_names_the_real_cause(tmp_path, capsys, case, expected):
    """``fit`` on a .mat whose signal is of another length or complex says so, in one line."""
    path = _short_and_complex_mat(tmp_path, case)
    assert main(["fit", str(path), "--method", "lm"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and expected in err
