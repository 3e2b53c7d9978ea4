"""``jadhesion fit``'s fast start: the Polach fit as a kept exported program.

:func:`fit_polach` and :func:`to_dataset` are drop-ins for
:func:`jadhesion.identify.polach_fit.fit_polach` and :func:`jadhesion.data.dataset.to_dataset` with
the same results, bit for bit. A process whose program cache (:func:`jadhesion.config.program_cache_dir`)
holds the fit for these shapes, options and code deserialises and calls it, with the compiled
executable from the persistent compilation cache: it imports neither the identification library
nor optimistix/equinox, and traces nothing. On a miss the library is imported, the fit exported,
kept and called (so its compilation lands in the compilation cache under the key a later process
looks up). The vehicle's gradient constant ``k_eps`` — about a second of eager JAX operations in a
new process — is remembered as the value it computed.

``JADHESION_PROGRAMS=0`` in the environment turns both off: the library is imported and traced as
before (for comparison and as a way out).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import os

import jax
import numpy as np

from ..config import program_cache_dir
from ..data import dataset as _dataset
from ..programs import ProgramCache, code_key

#: jadhesion sources that define the exported fit, and the libraries it is built from.
FIT_SOURCES = ("identify", "models", "data/dataset.py", "cli/fit_program.py")
FIT_DISTRIBUTIONS = ("optimistix", "equinox", "lineax")
#: Sources of ``Vehicle.k_eps`` (Hertz, Kalker's table, Polach's gradient constant).
K_EPS_SOURCES = (
    "models/contact.py",
    "models/polach.py",
    "data/vehicle.py",
    "resources/kalker_c_table_e3.csv",
)


@functools.cache
def _code(sources: tuple, distributions: tuple = ()) -> str:
    return code_key(sources, distributions)


def _enabled() -> bool:
    return os.environ.get("JADHESION_PROGRAMS", "1") != "0"


def _cache() -> ProgramCache:
    return ProgramCache(program_cache_dir())


def to_dataset(recording, observer_variant: str = "paper", creep: str = "smoothed"):
    """:func:`jadhesion.data.dataset.to_dataset` with ``k_eps`` remembered across processes
    (keyed on every vehicle field and the sources of ``k_eps``)."""
    vehicle = recording.vehicle
    if not _enabled():
        return _dataset.to_dataset(recording, observer_variant, creep)
    key = {"vehicle": dataclasses.asdict(vehicle), "code": _code(K_EPS_SOURCES)}
    k_eps = _cache().remember("k_eps", key, vehicle.k_eps)
    return _dataset.to_dataset(recording, observer_variant, creep, k_eps=k_eps)


@functools.cache
def _result_type(fields: tuple):
    return collections.namedtuple("PolachFit", fields)


def _polach_program(method, pop_size, max_iter, use_target):
    """The function kept as program ``polach_fit``: ``(dataset, key data, target) -> dict``."""
    # The fit command's one function-level import, on purpose: the identification library
    # (optimistix, equinox, every optimiser) is imported only on a cache miss, never on a warm start.
    from ..identify.polach_fit import fit_polach as library_fit

    def program(data, key_data, target):
        fit = library_fit(
            data,
            method,
            jax.random.wrap_key_data(key_data),
            pop_size=pop_size,
            max_iter=max_iter,
            target=target if use_target else None,
        )
        return fit._asdict()

    return program


def fit_polach(dataset, method: str, key, *, pop_size: int = 50, max_iter: int = 300, target=None):
    """:func:`jadhesion.identify.polach_fit.fit_polach` through a kept program (exported now on a
    miss). Returns a named tuple with :class:`~jadhesion.identify.polach_fit.PolachFit`'s fields
    (in alphabetical order), equal bit for bit to the library's result."""
    use_target = target is not None
    if not _enabled():
        out = _polach_program(method, pop_size, max_iter, use_target)(
            dataset, jax.random.key_data(key), target
        )
        return _result_type(tuple(out))(**out)
    static = {
        "method": method,
        "pop_size": int(pop_size),
        "max_iter": int(max_iter),
        "use_target": use_target,
        "prng": str(jax.random.key_impl(key)),
    }
    args = (
        dataset,
        jax.random.key_data(key),
        np.asarray(0.0 if target is None else target, dataset.adhesion.dtype),
    )
    code = _code(FIT_SOURCES, FIT_DISTRIBUTIONS)
    cache = _cache()
    program = cache.load("polach_fit", args, static=static, code=code)
    if program is not None:
        try:
            out = program(*args)
        except Exception:  # a kept program this process cannot run is rebuilt below, never fatal
            program = None
    if program is None:
        program = cache.export(
            "polach_fit",
            _polach_program(method, pop_size, max_iter, use_target),
            args,
            static=static,
            code=code,
        )
        out = program(*args)
    return _result_type(tuple(out))(**out)
