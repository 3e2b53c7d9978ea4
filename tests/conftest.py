"""Strict test settings: float64, no silent rank promotion, fixed keys (see STYLE.md §7).

The tests need nothing outside the repository (reference data is vendored in ``validation/data``) and
write nothing to the user's home: the CLI's compilation cache goes to a temporary folder.

The CLI turns JAX's persistent compilation cache on for its process (``enable_compilation_cache``).
Tests that call it in-process would leave it on for every later test of that worker, so every test
ends with the cache as the session began: XLA's executable serialisation (jaxlib 0.10.2, CPU) once aborted
a worker mid-suite in CI, in a library test that never asked for the cache.
"""

import os
import tempfile

import jax
import pytest
from jax.experimental.compilation_cache import compilation_cache

os.environ.setdefault("JADHESION_CACHE", tempfile.mkdtemp(prefix="jadhesion-test-cache-"))
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")


_CACHE_DIR = jax.config.jax_compilation_cache_dir  # off (None) unless the environment sets one


@pytest.fixture(autouse=True)
def _compilation_cache_off_between_tests():
    """After each test (and so after any module fixture that ran the CLI), put the persistent
    compilation cache back as the session began."""
    yield
    if jax.config.jax_compilation_cache_dir != _CACHE_DIR:
        jax.config.update("jax_compilation_cache_dir", _CACHE_DIR)
        compilation_cache.reset_cache()
