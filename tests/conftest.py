"""Strict test settings: float64, no silent rank promotion, fixed keys (see STYLE.md §7).

The tests need nothing outside the repository (reference data is vendored in ``validation/data``) and
write nothing to the user's home: the compilation cache goes to a temporary folder, removed when the
process that made it exits.

XLA compilation is most of the suite's time (46 of 65 s of tests/test_uncertainty.py alone), and the
workers and the CLI's subprocesses compile many of the same programs. So the whole session shares
JAX's persistent compilation cache (``enable_compilation_cache``, as the CLI does for a user): a
program one process compiled, the others load. Measured 2026-12-03 (2 workers): five of the slowest
files run back to back without and with it, 423 → 382 s; whole-suite runs 20 minutes apart, 17:58 →
15:42 — but fresh-clone CI runs two hours apart 17:35 → 17:37, within this machine's hourly spread.
A program loaded from the cache is the executable compiled, so bit-for-bit tests compare the same
code either way.

Every program XLA:CPU compiles holds a few memory maps for as long as JAX's caches keep it, and a
worker that runs half the suite compiles thousands: one reached 64 031 of Linux's default 65 530
(``vm.max_map_count``) in a whole-suite run, and in CI a worker died there, in LLVM's section
allocator. So after any file that leaves the worker above a quarter of the limit, JAX's caches are
cleared (:func:`jadhesion.memory_maps.release_if_near_limit`); the largest file adds about 25 000
maps. (XLA's executable serialisation (jaxlib 0.10.2, CPU) once aborted a worker late in its run,
in test_eiv: likely the same exhaustion.)
"""

import atexit
import os
import shutil
import tempfile

import jax
import pytest
from jax.experimental.compilation_cache import compilation_cache

from jadhesion.config import enable_compilation_cache
from jadhesion.memory_maps import release_if_near_limit

if "JADHESION_CACHE" not in os.environ:  # xdist workers and the CLI's subprocesses inherit it
    os.environ["JADHESION_CACHE"] = tempfile.mkdtemp(prefix="jadhesion-test-cache-")
    atexit.register(shutil.rmtree, os.environ["JADHESION_CACHE"], ignore_errors=True)
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
enable_compilation_cache()  # $JADHESION_CACHE: the folder above, or the one the caller chose
_CACHE_DIR = jax.config.jax_compilation_cache_dir


@pytest.fixture(autouse=True)
def _session_compilation_cache():
    """After each test, the session's cache folder again: a test that points ``JADHESION_CACHE``
    elsewhere and runs the CLI in-process moves the cache for the rest of its worker's run."""
    yield
    if jax.config.jax_compilation_cache_dir != _CACHE_DIR:
        jax.config.update("jax_compilation_cache_dir", _CACHE_DIR)
        compilation_cache.reset_cache()


#: Share of the kernel's memory-map limit above which a worker releases its compiled programs.
_RELEASE_SHARE = 0.25


#: The slowest files (CPU seconds of a whole-suite run with ``--durations``, slowest first). With
#: whole files per worker (``--dist loadfile --no-loadscope-reorder``, pyproject.toml) the files are
#: handed out in collection order, so a slow file collected last keeps one worker busy while the
#: others idle; handing the slowest out first (longest-processing-time-first scheduling) leaves only
#: short files for the tail. Without ``--no-loadscope-reorder`` xdist hands out the files with the
#: most tests first and this order has no effect.
SLOWEST_FILES = (
    "test_multifile.py",
    "test_cli.py",
    "test_optimisers.py",
    "test_notebooks.py",
    "test_diagnose.py",
    "test_uncertainty.py",
    "test_sweep.py",
    "test_programs.py",
    "test_mcmc.py",
    "test_effects.py",
    "test_simulator.py",
    "test_segments.py",
)


def pytest_collection_modifyitems(items):
    """Slowest files first (:data:`SLOWEST_FILES`); the order within a file is kept."""
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """After a file's last test (module fixtures torn down), release the compiled programs if the
    worker holds more than :data:`_RELEASE_SHARE` of the memory-map limit."""
    yield
    if nextitem is None or nextitem.path != item.path:
        release_if_near_limit(_RELEASE_SHARE)
