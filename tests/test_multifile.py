"""Many recordings in one process (issue #16 item 3): masks, length buckets, ``fit A B … | DIR``.

The contract: a file's result does not depend on the other files of the call, and the padded,
masked fit solves the unpadded problem (population methods bit for bit, LM to round-off).
"""

import csv
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion import LOCO_22E, memory_maps, polach_adhesion
from jadhesion.cli import main
from jadhesion.data.dataset import PolachDataset
from jadhesion.data.length_buckets import FINE_BUCKETS_FROM, SHORT_BUCKET, bucket_length
from jadhesion.identify import polach_fit
from jadhesion.identify.batch_fit import (
    buckets,
    fit_datasets,
    fit_datasets_vmapped,
    pad_dataset,
    valid_samples,
)
from jadhesion.identify.box_lm import box_lm
from jadhesion.identify.polach_fit import LM_RESIDUAL, SEED_SAMPLES, fit_polach, scaled, subsample
from jadhesion.identify.polach_residuals import polach_mae
from jadhesion.identify.trust import fit_report, jackknife_sd, trust_numbers
from jadhesion.memory_maps import map_count, map_limit
from jadhesion.models.polach import PARAM_NAMES

THETA = np.array([0.43, 0.6, 0.36, 0.36, 0.13])
SMALL = {"pop_size": 8, "max_iter": 25}  # population budgets: equality, not accuracy, is tested


def _columns(n, seed):
    rng = np.random.default_rng(seed)
    creep = np.sort(rng.uniform(1e-3, 0.3, n))
    speed = np.full(n, 0.6 + 0.1 * seed)
    mu = np.asarray(polach_adhesion(THETA, creep, creep * speed, LOCO_22E.k_eps()))
    return creep, speed, mu + 0.005 * rng.standard_normal(n)


def _dataset(n, seed):
    creep, speed, mu = _columns(n, seed)
    return PolachDataset(
        jnp.asarray(creep),
        jnp.asarray(creep * speed),
        jnp.asarray(mu),
        jnp.asarray(speed),
        jnp.asarray(LOCO_22E.k_eps()),
    )


def _write(path, n, seed):
    creep, speed, mu = _columns(n, seed)
    path.write_text(
        "creepage,vehicle_speed,adhesion\n"
        + "".join(
            f"{float(c)!r},{float(v)!r},{float(m)!r}\n" for c, v, m in zip(creep, speed, mu, strict=True)
        )
    )
    return path


def test_buckets_and_padding():
    assert SHORT_BUCKET == SEED_SAMPLES  # short data: LM seeds on all of it, padded or not
    assert [bucket_length(n) for n in (10, 128, 129, 256, 257, 1000, 2000, 2048, 2049)] == [
        128,
        128,
        256,
        256,
        512,
        1024,
        2048,
        2048,
        4096,
    ]
    data = _dataset(150, 0)
    padded = pad_dataset(data)
    assert padded.adhesion.shape == (256,) and valid_samples(padded) == 150
    assert np.all(np.asarray(padded.weight[:150]) == 1) and np.all(np.asarray(padded.weight[150:]) == 0)
    assert np.array_equal(padded.adhesion[:150], data.adhesion)
    # the padded MAE is the unpadded one; the LM's seeding subsample picks the same rows
    assert float(polach_mae(THETA, padded)) == pytest.approx(float(polach_mae(THETA, data)), rel=1e-14)
    sub, sub_padded = subsample(data), subsample(padded)
    assert np.array_equal(sub.adhesion, sub_padded.adhesion) and np.all(sub_padded.weight == 1)
    groups = buckets([_dataset(n, 0) for n in (150, 200, 300, 60)])
    assert sorted(idx for idx in groups.values()) == [[0, 1], [2], [3]]


def test_long_buckets_bound_the_padding():
    """Above FINE_BUCKETS_FROM samples a bucket wastes less than 1/8 of the work (an hour at
    100 Hz: 0.1 %), below it buckets are powers of two (few programs for short files)."""
    assert bucket_length(FINE_BUCKETS_FROM) == FINE_BUCKETS_FROM
    assert bucket_length(360_000) == 11 * 2**15
    for n in np.unique(np.geomspace(FINE_BUCKETS_FROM + 1, 5e6, 400).astype(int)):
        assert 0 <= bucket_length(n) - n < n / 8, n
    assert len({bucket_length(n) for n in range(2**18 + 1, 2**19 + 1, 997)}) == 8


def _uncertain(n, seed):
    """A dataset with the smoother's standard deviations (LM then fits the expected curve)."""
    data = _dataset(n, seed)
    return data._replace(slip_sd=0.02 * data.slip + 1e-4, creep_sd=0.02 * data.creep + 1e-5)


def test_padded_subsample_keeps_the_slip_uncertainty():
    data = _uncertain(700, 2)
    sub, sub_padded = subsample(data), subsample(pad_dataset(data))
    for name in ("creep", "slip", "adhesion", "slip_sd", "creep_sd"):
        np.testing.assert_array_equal(getattr(sub_padded, name), getattr(sub, name), err_msg=name)
    a = fit_polach(data, "lm", jax.random.key(0), pad=False)
    b = fit_polach(pad_dataset(data), "lm", jax.random.key(0))
    np.testing.assert_allclose(b.params, a.params, rtol=1e-12, atol=1e-12)


def test_blocked_linearisation_equals_one_piece_to_round_off():
    """LM's Jacobian reduced block by block (long recordings: memory of one block) takes the same
    steps to the same answer as in one piece, padded or not, with a remainder block or without."""
    box = (jnp.zeros(5), jnp.ones(5))
    for data in (_uncertain(700, 2), pad_dataset(_uncertain(700, 2))):
        one = box_lm(LM_RESIDUAL, jnp.full(5, 0.5), data, box)
        for block in (100, 128):
            blocked = box_lm(LM_RESIDUAL, jnp.full(5, 0.5), data, box, block_rows=block)
            np.testing.assert_allclose(blocked.params, one.params, rtol=1e-10, atol=1e-12)
            assert int(blocked.steps) == int(one.steps)
            assert float(blocked.sse) == pytest.approx(float(one.sse), rel=1e-12)


def test_weight_of_ones_is_bit_identical_to_no_weight():
    data = _dataset(300, 1)
    ones = data._replace(weight=jnp.ones(300))
    a = fit_polach(data, "lm", jax.random.key(0), pad=False)
    b = fit_polach(ones, "lm", jax.random.key(0))
    assert np.array_equal(a.params, b.params) and float(a.mae) == float(b.mae)


def test_fit_polach_compiles_one_program_per_bucket():
    """A loop of ``fit_polach`` over datasets of many lengths compiles once per length bucket (each
    program holds ~1000 memory maps: one per length exhausted Linux's limit after ~65 lengths), and
    a fit is the fit of its own samples (``pad=False``) bit for bit (one length here: each unpadded
    fit compiles a program of its own; padding's equality for every method and other lengths is
    :func:`test_population_methods_padded_equal_unpadded_bit_for_bit`)."""
    lengths = (520, 611, 777, 1024)  # one bucket: 1024
    assert {bucket_length(n) for n in lengths} == {1024}
    datasets = [_dataset(n, n % 7) for n in lengths]
    fits, programs = [], []
    for data in datasets:
        fits.append(fit_polach(data, "pso", jax.random.key(1), **SMALL))
        programs.append(polach_fit._fit_one._cache_size())
    assert programs == [programs[0]] * len(lengths)
    ref = fit_polach(datasets[1], "pso", jax.random.key(1), **SMALL, pad=False)
    assert np.array_equal(fits[1].params, ref.params)
    assert len({float(f.mae) for f in fits}) == len(lengths)  # each fit saw its own samples


def test_trust_block_is_computed_padded_and_equals_the_unpadded_one():
    """``fit_report`` computes the covariance on the dataset padded to its bucket (one program per
    bucket): the same standard errors to round-off, the same HAC bandwidth and the same peak as on
    its own samples; padding rows count in neither the degrees of freedom, the bandwidth nor the
    reference speed, nor in the jackknife's blocks (its refits agree to LM's tolerance)."""
    data = _uncertain(700, 2)
    fit = fit_polach(data, "lm", jax.random.key(0))
    report = fit_report(data, fit)
    numbers = trust_numbers(fit.params, scaled(data, fit))  # unpadded, directly
    cov, jackknife = numbers.cov, jackknife_sd(numbers.jackknife)
    assert report["hac_lags"] == int(numbers.lags)
    for i, name in enumerate(PARAM_NAMES):
        u = report["uncertainty"][name]
        if u["stderr"] is not None and np.isfinite(u["stderr"]):
            assert u["stderr_hac"] == pytest.approx(float(np.sqrt(cov[i, i])), rel=1e-9), name
            assert u["stderr_jackknife"] == pytest.approx(jackknife[i], rel=1e-5), name
            assert u["stderr"] == max(u["stderr_hac"], u["stderr_jackknife"])
    # the peak: the median speed and largest creep of the real rows only, the same peak
    assert report["vehicle_speed"] == pytest.approx(float(numbers.speed), rel=1e-12)
    for j, name in enumerate(("mu_max", "creep_opt")):
        assert report["derived"][name]["value"] == pytest.approx(float(numbers.peak[j]), rel=1e-9)
    before = trust_numbers._cache_size()
    fit_report(_uncertain(800, 3), fit_polach(_uncertain(800, 3), "lm", jax.random.key(0)))
    assert trust_numbers._cache_size() == before  # 800 rows: the same 1024-row program


@pytest.mark.parametrize("method", ["itlbo", "pso"])
def test_population_methods_padded_equal_unpadded_bit_for_bit(method):
    """Padding enters a population method only through the shared objective (padded rows weigh 0):
    one TLBO variant and PSO stand for the three."""
    key = jax.random.key(3)
    for n, seed in ((60, 0), (300, 1)):
        data = _dataset(n, seed)
        a = fit_polach(data, method, key, **SMALL, pad=False)
        b = fit_polach(pad_dataset(data), method, key, **SMALL)
        assert np.array_equal(a.params, b.params), (method, n)
        assert int(a.iterations) == int(b.iterations) and int(a.status) == int(b.status)
        assert float(b.mae) == pytest.approx(float(a.mae), rel=1e-14)


def test_lm_padded_equals_unpadded_to_round_off():
    key = jax.random.key(0)
    for n, seed, rel in ((300, 1, 1e-12), (60, 0, 1e-6)):
        data = _dataset(n, seed)
        a = fit_polach(data, "lm", key, pad=False)
        b = fit_polach(pad_dataset(data), "lm", key)
        np.testing.assert_allclose(b.params, a.params, rtol=rel, atol=rel)
        assert float(b.mae) == pytest.approx(float(a.mae), rel=rel)


@pytest.mark.parametrize("method", ["lm", "itlbo"])
def test_vmapped_buckets_agree_with_one_at_a_time(method):
    datasets = [_dataset(n, s) for s, n in enumerate((150, 200, 300))]
    key = jax.random.key(1)
    one = fit_datasets(datasets, method, key, **SMALL)
    many = fit_datasets_vmapped(datasets, method, key, **SMALL)
    for f, g in zip(one, many, strict=True):
        np.testing.assert_allclose(g.params, f.fit.params, rtol=1e-10, atol=1e-12)


# ---- command line ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("campaign")
    return [_write(folder / f"run{i}.csv", n, i) for i, n in enumerate((150, 220, 400))]


def _fit(capsys, *argv):
    code = main(["fit", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.skipif(map_count() is None or map_limit() is None, reason="no /proc memory-map accounting")
def test_many_files_releasing_compiled_programs_after_each_give_the_same_results(files, capsys, monkeypatch):
    """``jadhesion fit DIR`` releases the compiled programs between files when the process nears
    the memory-map limit (:func:`jadhesion.memory_maps.release_if_near_limit`); the fits compiled
    again after a release are the same."""
    folder = files[0].parent

    def fits():
        # one slip law (--single-law): the release is the subject; each law's programs would compile again
        assert main(["fit", str(folder), "--method", "lm", "--single-law", "--json"]) == 0
        docs = json.loads(capsys.readouterr().out)["fits"]
        return [{k: f[k] for k in ("params", "mae", "status", "uncertainty")} for f in docs]

    calls = []
    release = memory_maps.release_if_near_limit
    monkeypatch.setattr("jadhesion.cli.fit_run.release_if_near_limit", lambda: calls.append(release()))
    kept = fits()
    assert len(calls) == len(files) and not any(calls)  # far below the limit: nothing released
    calls.clear()
    monkeypatch.setattr(memory_maps, "map_limit", lambda: 1)  # every check is "near the limit"
    released = fits()
    assert len(calls) == len(files) and all(calls)  # after each file's load
    assert released == kept


@pytest.mark.parametrize("method", ["lm", "pso"])
def test_many_files_equal_one_at_a_time(files, capsys, tmp_path, method):
    flags = ["--method", method, "--pop-size", "8", "--max-iter", "25", "--json"]
    code, out, _ = _fit(capsys, files[0].parent, *flags, "--out", tmp_path / "t.csv")
    assert code == 0
    fits = json.loads(out)["fits"]
    assert [f["file"] for f in fits] == [str(p) for p in files]
    for path, doc in zip(files, fits, strict=True):
        code, out, _ = _fit(capsys, path, *flags)
        single = json.loads(out)
        assert "fits" not in single and single["file"] == str(path)  # one file: its document alone
        assert set(doc) == set(single)
        assert doc["params"] == single["params"]  # bit for bit: the same program on the same data
        for key in (
            "mae",
            "status",
            "converged",
            "uncertainty",
            "correlation",
            "warnings",
            "iterations",
            "evaluations",
            "hac_lags",
            "creep",
            "derived",
            "vehicle_speed",
        ):
            assert doc[key] == single[key], key
    with open(tmp_path / "t.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["file"] for r in rows] == [str(p) for p in files]
    assert list(rows[0]) == [
        "file",
        "method",
        "kA",
        "kS",
        "mu0",
        "A",
        "B",
        "mae",
        "status",
        "converged",
        "stderr_kA",
        "stderr_kS",
        "stderr_mu0",
        "stderr_A",
        "stderr_B",
        "vehicle_speed",
        "mu_max",
        "stderr_mu_max",
        "creep_opt",
        "stderr_creep_opt",
    ]
    for row, doc in zip(rows, fits, strict=True):
        assert float(row["kS"]) == doc["params"]["kS"] and float(row["mae"]) == doc["mae"]
        s = doc["uncertainty"]["mu0"]["stderr"]
        assert row["stderr_mu0"] == ("" if s is None else repr(s))
        assert float(row["mu_max"]) == doc["derived"]["mu_max"]["value"]


def test_many_kiencke_fits_equal_one_at_a_time(files, capsys):
    """``fit --model kiencke`` on several files: padded to length buckets, each file's document
    equals its single-file one."""
    flags = ["--model", "kiencke", "--method", "lm", "--json"]
    code, out, _ = _fit(capsys, *files, *flags)
    assert code == 0
    fits = json.loads(out)["fits"]
    for path, doc in zip(files, fits, strict=True):
        code, out, _ = _fit(capsys, path, *flags)
        single = json.loads(out)
        assert doc["model"] == single["model"] == "kiencke"
        assert {k: v for k, v in doc.items() if k != "seconds"} == {
            k: v for k, v in single.items() if k != "seconds"
        }


def test_many_files_human_table_and_plots(files, capsys, tmp_path):
    code, out, _ = _fit(capsys, *files, "--method", "lm", "--plot", tmp_path / "plots")
    assert code == 0 and "3 files" in out and all(p.name in out for p in files)
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == sorted(
        f"{p.stem}.fit.png" for p in files
    )


def test_a_bad_file_fails_the_call_before_any_fit(files, capsys, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("creepage,vehicle_speed,adhesion\n0.01,0.6,0.3\n0.02,fast,0.3\n")
    out_csv = tmp_path / "out.csv"
    code, out, err = _fit(capsys, files[0], bad, files[1], "--json", "--out", out_csv)
    assert code == 2 and out == ""
    assert "bad.csv" in err and len(err.strip().splitlines()) == 1
    assert not out_csv.exists()
    few = _write(tmp_path / "few.csv", 5, 0)
    code, out, err = _fit(capsys, files[0], few, "--out", out_csv)
    assert code == 2 and out == "" and "few.csv" in err and not out_csv.exists()
    code, out, err = _fit(capsys, files[0], tmp_path / "missing.csv")
    assert code == 2 and "missing.csv" in err
    empty = tmp_path / "empty"
    empty.mkdir()
    code, out, err = _fit(capsys, empty)
    assert code == 2 and "holds no recording" in err
    code, out, err = _fit(capsys, files[0], "--out", tmp_path / "t.txt")
    assert code == 2 and "--out" in err and out == ""


def test_keep_going_fits_the_usable_files_and_lists_the_others(files, capsys, tmp_path):
    """``--keep-going``: a folder of logger files with one broken file is fitted, each good file
    exactly as alone, the broken one listed with its one-line reason (stderr and ``skipped``) and
    left out of ``--out``; with no usable file the call still exits 2 and writes nothing."""
    bad = tmp_path / "bad.csv"
    bad.write_text("creepage,vehicle_speed,adhesion\n0.01,0.6,0.3\n0.02,fast,0.3\n")
    out_csv = tmp_path / "out.csv"
    code, out, err = _fit(capsys, files[0], bad, files[1], "--method", "lm", "--keep-going", "--json")
    assert code == 0
    doc = json.loads(out)
    assert [f["file"] for f in doc["fits"]] == [str(files[0]), str(files[1])]
    assert [s["file"] for s in doc["skipped"]] == [str(bad)] and "row" in doc["skipped"][0]["error"]
    assert err.strip().splitlines() == [f"jadhesion: skipped: {doc['skipped'][0]['error']}"]
    code, alone, _ = _fit(capsys, files[1], "--method", "lm", "--json")
    assert json.loads(alone)["params"] == doc["fits"][1]["params"]
    code, out, _ = _fit(capsys, files[0], bad, "--method", "lm", "--keep-going", "--out", out_csv)
    assert code == 0 and "1 file(s) skipped" in out
    with out_csv.open() as fh:
        assert [r["file"] for r in csv.DictReader(fh)] == [str(files[0])]
    out_csv.unlink()
    code, out, err = _fit(capsys, bad, tmp_path / "missing.csv", "--keep-going", "--out", out_csv)
    assert code == 2 and out == "" and "none of the 2 files" in err and not out_csv.exists()
    code, out, err = _fit(capsys, bad, "--keep-going", "--out", out_csv)  # one file: its own one line
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and str(bad) in err
