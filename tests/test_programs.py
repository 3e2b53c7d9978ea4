"""Kept exported programs (jadhesion.programs) and the fit command's fast start (cli/fit_program):
results equal the library's bit for bit; damaged or stale files are rebuilt; keys follow shapes
and code."""

import ast
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.cli import fit_program
from jadhesion.data.dataset import PolachDataset, to_dataset
from jadhesion.data.recording import load_recording, save_recording
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.identify.likelihood import SLIP_LAWS
from jadhesion.identify.polach_fit import fit_polach
from jadhesion.identify.trust import trust_numbers
from jadhesion.programs import ProgramCache, code_key
from jadhesion.status import Status

ROOT = Path(__file__).resolve().parents[1]


def _dataset(n=200, seed=0):
    rng = np.random.default_rng(seed)
    creep = np.linspace(1e-4, 0.05, n)
    slip = creep * 10.0
    adhesion = 0.3 * np.tanh(80 * creep) + 0.002 * rng.standard_normal(n)
    return PolachDataset(
        jnp.asarray(creep), jnp.asarray(slip), jnp.asarray(adhesion), jnp.full(n, 10.0), jnp.asarray(129.88)
    )


@pytest.fixture
def programs(tmp_path, monkeypatch):
    monkeypatch.setenv("JADHESION_CACHE", str(tmp_path / "xla"))
    return ProgramCache(tmp_path / "xla" / "exported")


def _assert_same(fit, ref):
    for name, value in ref._asdict().items():
        got = getattr(fit, name)
        if value is None:
            assert got is None, name
        else:
            np.testing.assert_array_equal(np.asarray(got), np.asarray(value), err_msg=name)


@pytest.mark.parametrize("method", ["lm", "itlbo", "pso"])
def test_exported_fit_equals_library_bit_for_bit(programs, method, monkeypatch):
    data, key = _dataset(), jax.random.key(3)
    options = dict(pop_size=8, max_iter=6)
    ref = fit_polach(data, method, key, **options)
    first = fit_program.fit_polach(data, method, key, **options)  # miss: exported, kept, called
    assert len(list(programs.directory.glob("polach_fit-*.jaxexport"))) == 1
    second = fit_program.fit_polach(data, method, key, **options)  # hit: deserialised
    _assert_same(first, ref)
    _assert_same(second, ref)
    monkeypatch.setenv("JADHESION_PROGRAMS", "0")  # the way out: the library, traced as before
    _assert_same(fit_program.fit_polach(data, method, key, **options), ref)


def test_exported_fit_with_target_equals_library(programs):
    data, key = _dataset(), jax.random.key(1)
    ref = fit_polach(data, "tlbo", key, pop_size=8, max_iter=20, target=0.05)
    fit_program.fit_polach(data, "tlbo", key, pop_size=8, max_iter=20, target=0.05)
    _assert_same(fit_program.fit_polach(data, "tlbo", key, pop_size=8, max_iter=20, target=0.05), ref)


def test_seed_key_is_jax_random_key():
    """The key the fit command builds without running JAX is ``jax.random.key(seed)``."""
    for seed in (0, 1, 7, 2**31 - 1, 2**31, 2**32 - 1, 2**32, 2**32 + 5, 123456789012, 2**63 - 1):
        got, ref = fit_program.seed_key(seed), jax.random.key(seed)
        assert jax.random.key_impl(got) == jax.random.key_impl(ref)
        np.testing.assert_array_equal(jax.random.key_data(got), jax.random.key_data(ref), err_msg=str(seed))


def _double(x, y):
    return {"sum": 2.0 * x + y}


def test_corrupt_stale_and_truncated_files_are_rebuilt(tmp_path):
    cache = ProgramCache(tmp_path)
    args = (jnp.arange(3.0), jnp.asarray(1.0))
    calls = []

    def make():
        calls.append(1)
        return _double

    assert cache.load("double", args) is None and cache.last_miss == "missing"
    np.testing.assert_array_equal(cache.get_or_export("double", make, args)(*args)["sum"], [1.0, 3.0, 5.0])
    (path,) = tmp_path.glob("double-*.jaxexport")
    assert cache.load("double", args) is not None and cache.last_miss is None
    good = path.read_bytes()
    header, _, blob = good.partition(b"\n")

    meta = json.loads(header)
    junk = b"\x00junk" * 50
    damaged = [
        ("corrupt", header + b"\n" + blob[:-7] + b"garbage"),
        ("corrupt", header + b"\n" + blob[: len(blob) // 2]),  # truncated
        ("unreadable", b"not a header\n" + blob),
        ("unreadable", b"\xff\xfe" * 10),
        (
            "unreadable",
            json.dumps({**meta, "sha256": hashlib.sha256(junk).hexdigest()}).encode() + b"\n" + junk,
        ),  # intact checksum of bytes that are no program
        ("key mismatch", json.dumps({**meta, "key": {**meta["key"], "code": "old"}}).encode() + b"\n" + blob),
    ]
    for reason, content in damaged:
        path.write_bytes(content)
        assert cache.load("double", args) is None
        assert cache.last_miss.startswith(reason)
        out = cache.get_or_export("double", make, args)(*args)
        np.testing.assert_array_equal(out["sum"], [1.0, 3.0, 5.0])
        assert cache.load("double", args) is not None  # rebuilt in place
    assert len(calls) == 1 + len(damaged)
    assert not list(tmp_path.glob(".*.tmp"))  # atomic writes leave no temporary file


def test_key_follows_shapes_dtypes_static_options_and_code(tmp_path):
    cache = ProgramCache(tmp_path)
    args = (jnp.arange(3.0), jnp.asarray(1.0))
    path = cache.path(cache.key("p", args, static={"m": "lm"}, code="abc"))
    variants = [
        cache.key("p", (jnp.arange(4.0), jnp.asarray(1.0)), static={"m": "lm"}, code="abc"),
        cache.key("p", (jnp.arange(3, dtype=jnp.int32), jnp.asarray(1.0)), static={"m": "lm"}, code="abc"),
        cache.key("p", args, static={"m": "pso"}, code="abc"),
        cache.key("p", args, static={"m": "lm"}, code="abd"),
        cache.key("p", (args,), static={"m": "lm"}, code="abc"),
    ]
    assert len({path, *map(cache.path, variants)}) == 1 + len(variants)
    assert cache.path(cache.key("p", (jnp.ones(3), jnp.asarray(7.0)), static={"m": "lm"}, code="abc")) == path


def test_code_key_changes_with_the_sources(tmp_path, monkeypatch):
    import jadhesion.programs as programs_module

    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "b.py").write_text("y = 2\n")
    monkeypatch.setattr(programs_module, "_PACKAGE", tmp_path)
    before = code_key(["pkg", "b.py"], ["numpy"])
    assert code_key(["pkg", "b.py"], ["numpy"]) == before
    (tmp_path / "pkg" / "a.py").write_text("x = 2\n")
    assert code_key(["pkg", "b.py"], ["numpy"]) != before
    assert code_key(["pkg", "b.py"], ["numpy", "jax"]) != code_key(["pkg", "b.py"], ["numpy"])


def test_remembered_value_is_the_computed_one(tmp_path):
    cache = ProgramCache(tmp_path)
    value = 129.8844014360829 + 1e-13
    assert cache.remember("k", {"v": 1}, lambda: value) == value
    assert cache.remember("k", {"v": 1}, lambda: pytest.fail("recomputed")) == value
    assert cache.remember("k", {"v": 2}, lambda: 1.5) == 1.5
    for f in tmp_path.glob("k-*.json"):
        f.write_text("{broken")
    assert cache.remember("k", {"v": 1}, lambda: 2.5) == 2.5


def _raw_recording(tmp_path, n=400, seed=0, name="raw.csv"):
    """A recording of the four raw signals (numbers only, no simulator)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.02
    v = 5.0 + 0.1 * t + 1e-3 * rng.standard_normal(n)
    slip = 0.05 + 0.04 * np.sin(t) ** 2
    torque = 0.2 * LOCO_22E.axle_weight_n * LOCO_22E.wheel_radius_m * (1 + 0.05 * np.sin(3 * t))
    return load_recording(
        save_recording(
            {"time": t, "vehicle_speed": v, "wheel_speed": v + slip, "traction_torque": torque},
            LOCO_22E,
            tmp_path / name,
        )
    )


def test_dataset_and_trust_programs_equal_library_bit_for_bit(programs, tmp_path):
    """Observer + creep smoother and the trust block's covariance as kept programs: miss, hit and
    the library give the same numbers bit for bit; two lengths of one bucket (400 and 300 rows:
    512) keep one dataset program."""
    recording = _raw_recording(tmp_path)
    ref = to_dataset(recording)
    for _ in range(2):  # miss (exported), then hit (deserialised)
        got = fit_program.to_dataset(recording)
        _assert_same(got, ref)
    shorter = _raw_recording(tmp_path, n=300, seed=1, name="shorter.csv")
    _assert_same(fit_program.to_dataset(shorter), to_dataset(shorter, pad=False))
    assert len(list(programs.directory.glob("polach_dataset-*.jaxexport"))) == 1
    params = jnp.asarray([0.4, 1.0, 0.35, 0.3, 0.2])  # kS on its bound: held fixed
    want = trust_numbers(params, ref)
    for _ in range(2):
        got = fit_program.trust_numbers(params, ref)
        for name, value in want._asdict().items():
            np.testing.assert_array_equal(np.asarray(getattr(got, name)), np.asarray(value), err_msg=name)


def test_posterior_start_and_slip_node_programs_equal_library_bit_for_bit(programs, tmp_path, monkeypatch):
    """The posterior's other kept programs — its least-squares start and either slip law's nodes —
    give, on a miss and on a hit, what the library traced anew gives (``JADHESION_PROGRAMS=0``)
    bit for bit."""
    data = to_dataset(_raw_recording(tmp_path))

    def programs_out():
        return [fit_program.lm_start(data)] + [fit_program.slip_nodes(data, law) for law in SLIP_LAWS]

    kept = [programs_out(), programs_out()]  # miss (exported), then hit (deserialised)
    monkeypatch.setenv("JADHESION_PROGRAMS", "0")
    traced = programs_out()
    for got in kept:
        for a, b in zip(got, traced, strict=True):
            _assert_same(a, b)
    assert traced[0].status == int(Status.CONVERGED)
    assert all(np.isfinite(np.asarray(d.node_slips)).all() for d in traced[1:])


_LAPACK_PROBE = """
import sys, jax, numpy as np
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
from jadhesion.programs import ProgramCache
cache, a, b = ProgramCache(sys.argv[1]), np.array([[0.0, 2.0], [4.0, 1.0]]), np.array([2.0, 9.0])
plain = cache.get_or_export("plain", lambda: lambda a, b: a @ b, (a, b))
lapack = cache.get_or_export("lapack", lambda: jnp.linalg.solve, (a, b))
out = [np.asarray(plain(a, b)).tolist(), "scipy" in sys.modules]
out += [np.asarray(lapack(a, b)).tolist(), "scipy" in sys.modules]
print(out)
"""


def test_lapack_set_up_only_for_programs_that_call_lapack(tmp_path):
    """A kept program without a LAPACK call runs in a new process without JAX's LAPACK set-up
    (which imports scipy.linalg); one with a LAPACK call still gets it and gives the right
    answer."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}

    def run():
        argv = [sys.executable, "-c", _LAPACK_PROBE, str(tmp_path)]
        return subprocess.run(argv, env=env, capture_output=True, text=True, timeout=300, check=True).stdout

    run()  # exports and keeps both
    plain, scipy_after_plain, solved, scipy_after_lapack = ast.literal_eval(run().strip())
    assert plain == [18.0, 17.0] and not scipy_after_plain
    np.testing.assert_allclose(solved, [2.0, 1.0], rtol=1e-15)
    assert scipy_after_lapack


def test_warm_fit_process_loads_kept_programs_only(tmp_path):
    """A second ``jadhesion fit`` process on a recording (observer, smoother, LM fit, trust block)
    gives the same JSON, keeps nothing new (every program was kept by the first) and imports
    neither optimistix/equinox (LM of the Polach fit is the projected LM of identify/box_lm) nor
    matplotlib (no --plot) nor tqdm (no progress bar) nor pandas (the CSV reader takes pyarrow's
    buffers) nor scipy (no LAPACK call in the kept programs: identify/small_linalg). The start-up
    time itself is a benchmark: benchmarks/bench_startup.py."""
    recording = _raw_recording(tmp_path, n=300)
    cache = tmp_path / "xla"
    env = {
        **os.environ,
        "JADHESION_CACHE": str(cache),
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    probe = (
        "import sys, json; from jadhesion.cli import main;"
        "code = main(['fit', sys.argv[1], '--method', 'lm', '--json']);"
        "heavy = [m for m in ('optimistix', 'equinox', 'matplotlib', 'tqdm', 'pandas', 'scipy')"
        " if m in sys.modules];"
        "sys.stderr.write('HEAVY=' + json.dumps(heavy) + '\\n'); sys.exit(code)"
    )

    def run():
        return subprocess.run(
            [sys.executable, "-c", probe, str(recording.path)],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )

    first = run()
    kept = sorted(p.name for p in cache.rglob("*"))
    second = run()
    for r in (first, second):
        assert r.returncode == 0, r.stderr
    docs = [json.loads(r.stdout) for r in (first, second)]
    for d in docs:
        d.pop("seconds")
        d["slip_law_check"].pop("seconds")  # the other slip law's fit (its own kept programs)
    assert docs[0] == docs[1]
    assert {p.split("-")[0] for p in kept if p.endswith(".jaxexport")} == {
        "polach_dataset",
        "polach_slip_nodes",
        "polach_fit",
        "polach_trust",
    }
    assert sorted(p.name for p in cache.rglob("*")) == kept
    assert "HEAVY=[]" in second.stderr
