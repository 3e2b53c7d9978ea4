"""Sweeps: grid expansion, observation, table, chunking + resume, stale parts, devices and processes.

The subprocess runs (2 and 4 forced CPU devices; two ``jax.distributed`` processes of 2 devices each
on localhost) start first and overlap the in-process reference run (1 device); all use the cheap
analytic source of ``_sweep_worker.py`` and must reproduce the reference table bit for bit (the
``seconds`` column aside).
"""

import argparse
import importlib.util
import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from _sweep_worker import toy_grid, toy_simulate
from jadhesion.cli import main as cli_main
from jadhesion.cli.common import UserError
from jadhesion.cli.sweep_run import _check_chunk_memory
from jadhesion.data.dataset import PolachDataset
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.errors import InputError
from jadhesion.models.polach import PARAM_NAMES, polach_adhesion
from jadhesion.sweeps import (
    COLUMNS,
    Grid,
    code_hash,
    observe,
    parts_dir,
    plan,
    read_table,
    run_sweep,
    runner,
    source_digest,
    write_table,
)

REPO = Path(__file__).resolve().parents[1]
WORKER = REPO / "tests" / "_sweep_worker.py"
TIMEOUT = 300
CHUNK = 5


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: A real sweep (simulated 22E tests, improved TLBO) whose table, when a chunk of 16 was sharded as
#: 4 points per device, differed from the one-device table in the last bits of 4 of its 16 MAEs.
CLI_SWEEP = (
    "sweep",
    "--scenarios",
    "dry",
    "--seeds",
    "8",
    "--methods",
    "itlbo",
    "--pop-size",
    "20",
    "--max-iter",
    "60",
    "--samples",
    "500",
    "--noise",
    "1,2",
    "--chunk-size",
    "16",
    "--json",
)


def _worker(out, *extra):
    """Arguments of a ``_sweep_worker.py`` run of the toy grid into ``out``."""
    return [str(WORKER), str(out), "--chunk-size", str(CHUNK), *extra]


def _spawn(argv, devices=None, *, cache):
    """Start ``python argv…`` with ``devices`` forced CPU devices and the test's compilation cache."""
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
        JADHESION_CACHE=str(cache),
        JAX_NUMPY_RANK_PROMOTION="raise",
        JAX_PLATFORMS="cpu",
    )
    env.pop("XLA_FLAGS", None)
    if devices:
        env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
    return subprocess.Popen(
        [sys.executable, *argv], env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _finish(proc) -> dict:
    try:
        stdout, stderr = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"sweep worker timed out after {TIMEOUT} s")
    assert proc.returncode == 0, stderr[-3000:]
    try:
        return json.loads(stdout)  # the CLI's one document
    except json.JSONDecodeError:  # the worker's last line: Gloo (CPU collectives) prints on stdout too
        return json.loads([line for line in stdout.splitlines() if line.startswith("{")][-1])


@pytest.fixture(scope="module")
def workers(tmp_path_factory):
    """Subprocess sweeps of the toy grid: 4 forced devices, and 2 processes × 2 devices (two
    devices per process are exercised there; a separate 2-device run cost ~13 s of CPU)."""
    root = tmp_path_factory.mktemp("workers")
    cache = root / "xla-cache"
    address = f"127.0.0.1:{_free_port()}"
    procs = {"devices4": _spawn(_worker(root / "devices4.csv"), 4, cache=cache)}
    for n in (1, 4):
        procs[f"cli{n}"] = _spawn(
            ["-m", "jadhesion", *CLI_SWEEP, "--out", str(root / f"cli{n}.csv")], n, cache=cache
        )
    for i in range(2):
        dist = ("--coordinator", address, "--num-processes", "2", "--process-id", str(i))
        procs[f"rank{i}"] = _spawn(_worker(root / "dist.csv", *dist), 2, cache=cache)
    yield root, procs
    for proc in procs.values():  # a worker no selected test read still holds its pipes open
        if proc.poll() is None:
            proc.kill()
        proc.stdout.close()
        proc.stderr.close()
        proc.wait()


@pytest.fixture(scope="module")
def reference(workers, tmp_path_factory):
    """The toy grid run in this process on one device (after the workers have started)."""
    out = tmp_path_factory.mktemp("reference") / "sweep.csv"
    table, summary = run_sweep(toy_grid(), out, chunk_size=CHUNK, simulate=toy_simulate)
    return out, table, summary


def _assert_same(a, b):
    """Equal bit for bit (floats compared as their 64-bit patterns), ``seconds`` aside."""
    for c in COLUMNS:
        if c == "seconds":
            continue
        x, y = np.asarray(a[c]), np.asarray(b[c])
        if x.dtype == np.float64:
            x, y = x.view(np.int64), y.view(np.int64)
        np.testing.assert_array_equal(x, y, err_msg=c)


def test_grid_expansion_and_chunks():
    grid = Grid(
        scenarios=["dry", "wet"], seeds=range(3), methods=["lm", "pso"], noise_scale=[1, 2], creep_max=[0.1]
    )
    assert grid.size == 2 * 3 * 2 * 2 and grid.per_seed == 2
    chunks = plan(grid, 4)
    assert [c.index for c in chunks] == list(range(len(chunks))) == list(range(8))
    assert [(c.scenario, c.method, len(c.points)) for c in chunks[:2]] == [("dry", "lm", 4), ("dry", "lm", 2)]
    cell = np.concatenate([c.points for c in chunks[:2]])
    np.testing.assert_array_equal(cell, [[s, n, 0] for s in range(3) for n in range(2)])
    assert sum(len(c.points) for c in chunks) == grid.size
    for bad in (
        dict(scenarios=["ice"]),
        dict(methods=["bfgs"]),
        dict(seeds=[]),
        dict(seeds=[1, 1]),
        dict(noise_scale=[-1.0]),
        dict(noise_scale=[1e300]),  # ran, its fits "converged"
        dict(creep_max=[0.0]),
        dict(n_samples=10),
    ):
        with pytest.raises(InputError):
            Grid(**bad)
    with pytest.raises(InputError):
        plan(grid, 0)


def test_observe_scales_noise_and_selects_creep_range():
    theta = jnp.asarray(SCENARIOS["dry"].params)
    creep = jnp.asarray([0.3, 0.01, 0.2, 0.02, 0.05, 0.5])
    curve = polach_adhesion(theta, creep, creep, 130.0)
    noise = jnp.asarray([1.0, -1.0, 2.0, -2.0, 0.5, 0.0]) * 1e-2
    data = PolachDataset(creep, creep, curve + noise, jnp.ones(6), jnp.asarray(130.0))
    observe_ = jax.jit(observe)
    same, covered = observe_(data, theta, 1.0, math.inf)
    np.testing.assert_allclose(same.adhesion, data.adhesion, rtol=0, atol=1e-15)
    assert int(covered) == 6
    clean, _ = observe_(data, theta, 0.0, math.inf)
    np.testing.assert_allclose(clean.adhesion, curve, rtol=0, atol=1e-15)
    low, covered = observe_(data, theta, 2.0, 0.05)
    assert int(covered) == 3
    np.testing.assert_array_equal(low.creep, [0.01, 0.01, 0.02, 0.02, 0.05, 0.05])
    np.testing.assert_allclose(
        low.adhesion - polach_adhesion(theta, low.creep, low.slip, 130.0),
        2.0 * np.array([-1.0, -1.0, -2.0, -2.0, 0.5, 0.5]) * 1e-2,
        atol=1e-14,
    )
    none, covered = observe_(data, theta, 1.0, 1e-3)
    assert int(covered) == 0 and np.all(none.creep == 0.01)


def test_table_columns_and_csv_round_trip(reference):
    out, table, summary = reference
    grid = toy_grid()
    assert tuple(table) == COLUMNS and len(table["seed"]) == grid.size == summary.fits
    assert summary.computed == grid.size and summary.processes == 1
    assert list(table["scenario"][:12]) == ["dry"] * 12 and list(table["seed"][:4]) == [0] * 4
    np.testing.assert_array_equal(table["noise_scale"][:4], [0.5, 0.5, 2.0, 2.0])
    np.testing.assert_array_equal(table["creep_max"][:2], [0.05, math.inf])
    for i, p in enumerate(PARAM_NAMES):
        assert np.all(table[f"true_{p}"][12:] == SCENARIOS["sand"].params[i])
    assert np.all((table["samples"] > 0) & (table["samples"] <= 120))
    assert np.all(table["samples"][1::2] == 120)
    assert np.all(np.isfinite(table["mae"])) and np.all(table["seconds"] > 0)
    assert set(table["status"]) <= {"unknown", "converged", "max_steps", "stalled", "nonfinite"}
    assert np.all(np.abs(table["mu_max"] / table["true_mu_max"] - 1) < 0.2)
    _assert_same(read_table(out), table)
    assert np.array_equal(read_table(out)["seconds"], table["seconds"])


def test_a_creep_range_with_too_few_samples_is_not_run(tmp_path):
    """A --creep-max that keeps fewer samples than a fit needs (10) gives status not_run: its fit
    ran on copies of 2 samples and reported 'converged'. Its numbers are NaN (empty), so that no
    aggregate over the table takes them for a fit; the other rows' are finite."""
    grid = Grid(
        scenarios=("dry",),
        seeds=(0, 1),
        methods=("pso",),
        noise_scale=(1.0,),
        creep_max=(0.0022, math.inf),
        fit_options=toy_grid().fit_options,
    )
    table, _ = run_sweep(grid, tmp_path / "few.csv", chunk_size=CHUNK, simulate=toy_simulate)
    few = table["samples"] < 10
    assert few[0::2].all() and not few[1::2].any()
    assert set(table["status"][few]) == {"not_run"} and "not_run" not in set(table["status"][~few])
    for column in (*PARAM_NAMES, "mae", "mu_max", "creep_opt"):
        assert np.isnan(table[column][few]).all() and np.isfinite(table[column][~few]).all(), column
    assert np.isfinite(table["true_mu_max"]).all()


def test_resume_recomputes_only_missing_chunk(reference, tmp_path):
    out, table, _ = reference
    parts = parts_dir(out, toy_grid(), CHUNK, toy_simulate)
    files = sorted(parts.glob("chunk-*.csv"))
    assert len(files) == len(plan(toy_grid(), CHUNK)) == 6
    stamps = {f.name: f.stat().st_mtime_ns for f in files}
    files[2].unlink()
    again, summary = run_sweep(toy_grid(), out, chunk_size=CHUNK, simulate=toy_simulate)
    assert (summary.chunks_computed, summary.computed) == (1, len(plan(toy_grid(), CHUNK)[2].points))
    assert {f.name: f.stat().st_mtime_ns for f in files if f != files[2]} == {
        k: v for k, v in stamps.items() if k != files[2].name
    }
    _assert_same(again, table)


def test_stale_parts_after_a_code_change_are_recomputed(reference, monkeypatch):
    out, table, _ = reference
    old = parts_dir(out, toy_grid(), CHUNK, toy_simulate)
    stamps = {f: f.stat().st_mtime_ns for f in old.glob("chunk-*.csv")}
    monkeypatch.setattr(runner, "code_hash", lambda simulate=None, devices=None: "changed-code")
    new = parts_dir(out, toy_grid(), CHUNK, toy_simulate)
    assert new != old and new.parent == old.parent
    again, summary = run_sweep(toy_grid(), out, chunk_size=CHUNK, simulate=toy_simulate)
    assert (summary.chunks_computed, summary.computed) == (len(stamps), toy_grid().size)
    assert summary.parts == str(new) and len(list(new.glob("chunk-*.csv"))) == len(stamps)
    assert {f: f.stat().st_mtime_ns for f in old.glob("chunk-*.csv")} == stamps
    _assert_same(again, table)


def test_code_hash_follows_the_source(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "b.txt").write_text("not code")
    before = source_digest(["pkg"], tmp_path)
    (pkg / "b.txt").write_text("still not code")
    assert source_digest(["pkg"], tmp_path) == before
    (pkg / "a.py").write_text("x = 2\n")
    assert source_digest(["pkg"], tmp_path) != before
    assert code_hash() == code_hash() != code_hash(toy_simulate)


def test_four_devices_give_the_single_device_table_bit_for_bit(workers, reference):
    root, procs = workers
    summary = _finish(procs["devices4"])
    assert summary["devices"] == 4 and summary["computed"] == toy_grid().size
    _assert_same(read_table(root / "devices4.csv"), reference[1])


def test_real_sweep_on_four_devices_gives_the_one_device_table_bit_for_bit(workers):
    root, procs = workers
    summaries = [_finish(procs[f"cli{n}"]) for n in (1, 4)]
    assert [s["devices"] for s in summaries] == [1, 4] and summaries[1]["fits"] == 16
    _assert_same(read_table(root / "cli4.csv"), read_table(root / "cli1.csv"))


def test_two_processes_give_the_single_process_table_bit_for_bit(workers, reference):
    root, procs = workers
    summaries = [_finish(procs[f"rank{i}"]) for i in range(2)]
    assert [s["processes"] for s in summaries] == [2, 2] and summaries[0]["devices"] == 4
    assert sum(s["chunks_computed"] for s in summaries) == len(plan(toy_grid(), CHUNK))
    assert summaries[0]["out"] and summaries[1]["out"] is None
    _assert_same(read_table(root / "dist.csv"), reference[1])


@pytest.mark.skipif(importlib.util.find_spec("pyarrow") is None, reason="pyarrow not installed")
def test_parquet_round_trip(reference, tmp_path):
    table = reference[1]
    path = write_table(table, tmp_path / "sweep.parquet")
    back = read_table(path)
    _assert_same(back, table)
    assert np.array_equal(back["seconds"], table["seconds"])


def test_cli_bad_arguments_exit_2(tmp_path, capsys):
    out = tmp_path / "x.csv"
    for argv in (
        ["--scenarios", "dry,ice"],
        ["--methods", "newton"],
        ["--seeds", "0"],
        ["--chunk-size", "0"],
        ["--creep-max", "-1"],
        ["--max-iter", "0"],
        ["--scenarios", "dry,,wet"],  # an empty item was dropped
        ["--noise", "1,x"],
        ["--samples", "10"],  # the flag's range said [10, ...], the grid then refused it
    ):
        assert cli_main(["sweep", *argv, "--out", str(out), "--json"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("jadhesion: error:") and err.count("\n") == 1
        expected = "jadhesion: error: sweep: --samples must be in [100, 200000], got 10\n"
        assert argv[0] != "--samples" or err == expected
    assert list(tmp_path.iterdir()) == []


def test_cli_out_must_be_a_table_file_in_an_existing_directory(tmp_path, capsys):
    """As simulate's --out: refused at once, nothing made (a missing directory was created, a
    .txt written as CSV, a directory named .csv failed after the fits)."""
    (tmp_path / "d.csv").mkdir()
    for out, words in (
        ("d.csv", "is a directory"),
        ("x.txt", "expected a .csv or .parquet file name"),
        ("missing/x.csv", "does not exist"),
    ):
        argv = ["sweep", "--scenarios", "dry", "--seeds", "1", "--samples", "100", "--out"]
        assert cli_main([*argv, str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--out" in err and words in err
    assert list(tmp_path.iterdir()) == [tmp_path / "d.csv"]


@pytest.mark.slow
def test_cli_end_to_end(tmp_path):
    out = tmp_path / "sweep.csv"
    cmd = [
        sys.executable,
        "-m",
        "jadhesion",
        "sweep",
        "--scenarios",
        "dry",
        "--seeds",
        "1",
        "--methods",
        "pso",
        "--pop-size",
        "10",
        "--max-iter",
        "10",
        "--noise",
        "1,2",
        "--samples",
        "100",
        "--chunk-size",
        "2",
        "--out",
        str(out),
        "--json",
    ]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    doc = json.loads(proc.stdout)
    for key in ("fits", "seconds", "fits_per_second", "devices", "processes", "out"):
        assert key in doc
    assert doc["fits"] == 2 and doc["processes"] == 1 and doc["out"] == str(out)
    table = read_table(out)
    assert list(table["noise_scale"]) == [1.0, 2.0] and np.all(np.isfinite(table["kA"]))


def test_default_chunk_shrinks_to_fit_a_given_one_is_checked():
    """Without --chunk-size a chunk is 64 fits, or as many as keep one evaluation within 1 GiB
    (200 000 samples of improved TLBO, populations of 50: 13); a given --chunk-size beyond that
    is refused naming the largest that fits."""
    big = argparse.Namespace(chunk_size=None, pop_size=None, samples=200_000)
    _check_chunk_memory(big, ["itlbo"])
    assert big.chunk_size == 13
    small = argparse.Namespace(chunk_size=None, pop_size=None, samples=2000)
    _check_chunk_memory(small, ["itlbo", "lm"])
    assert small.chunk_size == 64
    with pytest.raises(UserError, match="use --chunk-size 13 or less"):
        _check_chunk_memory(argparse.Namespace(chunk_size=64, pop_size=None, samples=200_000), ["itlbo"])
