"""Compiled programs released before the process runs out of memory maps (``jadhesion.memory_maps``)."""

import json

import jax
import numpy as np
import pytest

from jadhesion import LOCO_22E, memory_maps, polach_adhesion
from jadhesion.cli import main
from jadhesion.memory_maps import map_count, map_limit, release_if_near_limit

THETA = np.array([0.43, 0.6, 0.36, 0.36, 0.13])

needs_proc = pytest.mark.skipif(
    map_count() is None or map_limit() is None, reason="no /proc memory-map accounting here"
)


@needs_proc
def test_release_clears_the_caches_only_above_the_share():
    f = jax.jit(lambda x: 2.0 * x)
    f(1.0)
    assert 0 < map_count() <= map_limit()
    assert not release_if_near_limit(1.0) and f._cache_size() == 1
    assert release_if_near_limit(0.0) and f._cache_size() == 0


def _write(path, n, seed):
    rng = np.random.default_rng(seed)
    creep = np.sort(rng.uniform(1e-3, 0.3, n))
    speed = np.full(n, 0.7)
    mu = np.asarray(polach_adhesion(THETA, creep, creep * speed, LOCO_22E.k_eps()))
    mu = mu + 0.005 * rng.standard_normal(n)
    rows = "".join(f"{c:.17g},{v:.17g},{m:.17g}\n" for c, v, m in zip(creep, speed, mu, strict=True))
    path.write_text("creepage,vehicle_speed,adhesion\n" + rows)


@needs_proc
def test_fit_of_many_files_releasing_after_each_gives_the_same_results(tmp_path, capsys, monkeypatch):
    """``jadhesion fit DIR`` releases the compiled programs between files when the process nears
    the limit; the fits compiled again after a release are the same."""
    for i, n in enumerate((150, 230)):
        _write(tmp_path / f"r{i}.csv", n, i)

    def fits():
        assert main(["fit", str(tmp_path), "--method", "lm", "--json"]) == 0
        return [
            {k: f[k] for k in ("params", "mae", "status", "uncertainty")}
            for f in json.loads(capsys.readouterr().out)["fits"]
        ]

    calls = []
    release = memory_maps.release_if_near_limit
    monkeypatch.setattr("jadhesion.cli.fit_run.release_if_near_limit", lambda: calls.append(release()))
    kept = fits()
    assert calls and not any(calls)  # far below the limit: nothing released
    calls.clear()
    monkeypatch.setattr(memory_maps, "map_limit", lambda: 1)  # every check is "near the limit"
    released = fits()
    assert len(calls) == 2 and all(calls)  # after each file's load
    assert released == kept
