"""Compiled programs released before the process runs out of memory maps (``jadhesion.memory_maps``;
``jadhesion fit DIR`` releasing between files: ``test_multifile``)."""

import jax
import pytest

from jadhesion.memory_maps import map_count, map_limit, release_if_near_limit

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
