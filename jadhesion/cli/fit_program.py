"""``jadhesion fit``'s (and ``posterior``'s) fast start: the commands' JAX work as kept exported programs.

Five programs, each exported once (``jax.export``) and kept in the program cache
(:func:`jadhesion.config.program_cache_dir`, :mod:`jadhesion.programs`) under its shapes, options
and code: ``polach_dataset`` (observer, kinematics and Kalman/RTS creep smoother of a recording's
raw signals padded to their length bucket: :func:`to_dataset`), ``polach_slip_nodes`` (the slip
law's nodes: :func:`slip_nodes`), ``polach_fit`` (the fit of a padded dataset: :func:`fit_polach`),
``polach_trust`` (the Jacobian of LM's residual over every row, the HAC covariance, the
curve's peak with its gradient and the block jackknife's refits: :func:`trust_numbers`) and, for
``jadhesion posterior``, ``polach_lm_start`` (its least-squares start: :func:`lm_start`). Each is
a drop-in for its library function with the same results, bit for bit; a program used twice in a
process (the fit under both slip laws) is loaded once. A process that finds them
deserialises and calls them, with the compiled executables from the persistent compilation cache:
it traces and lowers nothing, and imports no optimistix or equinox (the fit's LM is the projected
LM of :mod:`jadhesion.identify.box_lm`). On a miss the library function is exported, kept and
called (so its compilation lands in the compilation cache under the key a later process looks up).
The vehicle's gradient constant ``k_eps`` — about a second of eager JAX operations in a new process
— is remembered as the value it computed.

``JADHESION_PROGRAMS=0`` in the environment turns all of this off: the library is called and
traced as before (for comparison and as a way out).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import os
import types

import jax
import jax.numpy as jnp
import numpy as np

from ..config import program_cache_dir
from ..data import dataset as _dataset
from ..data.length_buckets import bucket_length
from ..identify.batch_fit import bucketed
from ..programs import ProgramCache, code_key

#: jadhesion sources that define the exported fit, and the libraries it is built from.
FIT_SOURCES = ("identify", "models", "data/dataset.py", "cli/fit_program.py")
FIT_DISTRIBUTIONS = ("optimistix", "equinox", "lineax")
#: Sources of the dataset program (observer, kinematics, creep smoother).
DATASET_SOURCES = (
    "data/dataset.py",
    "data/observer.py",
    "data/creep_state.py",
    "data/vehicle.py",
    "models",
    "cli/fit_program.py",
)
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


#: The vehicle's numbers the observer and the smoother read (arguments of the dataset program).
VEHICLE_FIELDS = ("wheelset_inertia_kgm2", "wheel_radius_m", "axle_load_kg", "observer_time_constant_s")


def _dataset_program(observer_variant, creep):
    """The function kept as program ``polach_dataset``: ``(raw signals padded to their length
    bucket, vehicle numbers, k_eps, mask of the real rows) -> dataset dict`` (observer, kinematics
    and creep smoother). The vehicle's numbers are arguments, as in the library's calls, so that
    the compiled arithmetic is the same."""

    def program(columns, vehicle, k_eps, valid):
        signals = _dataset.Signals(columns, types.SimpleNamespace(**vehicle))
        return _dataset.to_dataset(signals, observer_variant, creep, k_eps=k_eps, valid=valid)._asdict()

    return program


def to_dataset(recording, observer_variant: str = "paper", creep: str = "smoothed"):
    """:func:`jadhesion.data.dataset.to_dataset` with ``k_eps`` remembered across processes
    (keyed on every vehicle field and the sources of ``k_eps``) and, for a recording with the raw
    signals, the observer and the creep smoother run as a kept program (keyed on the length bucket,
    :func:`jadhesion.data.length_buckets.bucket_length`, and the options); the same dataset bit for
    bit."""
    vehicle = recording.vehicle
    if not _enabled():
        return _dataset.to_dataset(recording, observer_variant, creep)
    key = {"vehicle": dataclasses.asdict(vehicle), "code": _code(K_EPS_SOURCES)}
    k_eps = _cache().remember("k_eps", key, vehicle.k_eps)
    if _dataset.adhesion_source(recording) == "column":  # a fitting dataset: a few array operations
        return _dataset.to_dataset(recording, observer_variant, creep, k_eps=k_eps)
    n = len(recording.columns["time"])
    columns, valid = _dataset.padded_signals(recording.columns, bucket_length(n))
    args = (columns, {f: np.asarray(getattr(vehicle, f)) for f in VEHICLE_FIELDS}, np.asarray(k_eps), valid)
    static = {"observer_variant": observer_variant, "creep": creep}
    make = functools.partial(_dataset_program, observer_variant, creep)
    out = _kept("polach_dataset", make, args, static, DATASET_SOURCES)
    # NumPy arrays: the selection's masking and the padding then run no eager JAX operation
    return _dataset.cut(_dataset.PolachDataset(**jax.tree.map(np.asarray, out)), n)


@functools.cache
def _result_type(fields: tuple, name: str = "PolachFit"):
    return collections.namedtuple(name, fields)


def _polach_program(method, pop_size, max_iter, target):
    """The function kept as program ``polach_fit``: ``(dataset, key data) -> dict``; ``target``
    (a float or ``None``) is one of its static options, checked by the library here, before
    tracing."""
    # The fit command's one function-level import, on purpose: the fitting library is imported
    # only on a cache miss, never on a warm start.
    from ..identify.polach_fit import fit_polach as library_fit

    def program(data, key_data):
        key = jax.random.wrap_key_data(key_data)
        fit = library_fit(data, method, key, pop_size=pop_size, max_iter=max_iter, target=target)
        return fit._asdict()

    return program


def _trust_program():
    """The function kept as program ``polach_trust``: ``(params, dataset) -> dict`` of
    :class:`~jadhesion.identify.trust.TrustNumbers`' fields."""
    from ..identify.trust import trust_numbers  # on a miss only, as above

    return lambda params, data: trust_numbers(params, data)._asdict()


#: The programs this process has loaded or exported, by key: a second call (the fit under the
#: other slip law, the next file of a bucket) runs the one JAX compiled, instead of loading it again.
_LOADED = {}


def _kept(name, make_fn, args, static, sources=None):
    """``make_fn()``'s function called on ``args`` through the kept program ``name`` (exported
    and kept now on a miss; a kept program this process cannot run is rebuilt, never fatal);
    ``sources``: the code it is keyed on (default the fit's)."""
    code = _code(FIT_SOURCES, FIT_DISTRIBUTIONS) if sources is None else _code(sources)
    cache = _cache()
    memo = cache.path(cache.key(name, args, static=static, code=code))
    program = _LOADED.get(memo) or cache.load(name, args, static=static, code=code)
    if program is not None:
        try:
            out = program(*args)
            _LOADED[memo] = program
            return out
        except Exception:  # rebuilt below
            pass
    _LOADED[memo] = cache.export(name, make_fn(), args, static=static, code=code)
    return _LOADED[memo](*args)


def _nodes_program(law):
    """The function kept as program ``polach_slip_nodes``: ``padded dataset -> node slips``."""
    from ..identify.likelihood import with_node_slips  # on a miss only, as the fit's

    return lambda data: with_node_slips(data, law).node_slips


def slip_nodes(dataset, law: str):
    """``dataset`` (with a slip sd) with the node slips of slip law ``law`` set
    (:func:`jadhesion.identify.likelihood.with_node_slips` on the dataset padded to its length
    bucket, cut back to its rows) through the kept program ``polach_slip_nodes``: set for either
    law, so the fits and trust blocks under both laws are one program each."""
    n = dataset.adhesion.shape[0]
    padded = bucketed(dataset._replace(node_slips=None))
    if not _enabled():
        nodes = jax.jit(_nodes_program(law))(padded)
    else:
        make = functools.partial(_nodes_program, law)
        nodes = _kept("polach_slip_nodes", make, (padded,), {"law": law})
    return dataset._replace(node_slips=jnp.asarray(np.asarray(nodes)[:n]))


def _start_program(observer: bool):
    """The function kept as program ``polach_lm_start``: ``(dataset[, observer terms]) -> dict`` of
    :class:`~jadhesion.identify.lm_result.LMResult`'s fields, the posterior's least-squares start."""
    from ..identify.laplace import lm_start as library_start  # on a miss only, as the fit's

    if observer:
        return lambda data, obs: library_start(data, obs=obs)._asdict()
    return lambda data: library_start(data)._asdict()


def lm_start(dataset, obs=None):
    """:func:`jadhesion.identify.laplace.lm_start` (the box LM from every start, the best converged
    one with its status; with ``obs``, of the observer's view) through a kept program, keyed on the
    dataset's shapes; a named tuple with ``LMResult``'s fields (in alphabetical order)."""
    args = (dataset,) if obs is None else (dataset, obs)
    make = functools.partial(_start_program, obs is not None)
    static = {"observer": obs is not None}
    out = make()(*args) if not _enabled() else _kept("polach_lm_start", make, args, static)
    return _result_type(tuple(out), "LMResult")(**out)


def seed_key(seed: int):
    """``jax.random.key(seed)`` built without running JAX: with the default threefry2x32
    implementation a seed's key is the seed bit-cast to two ``uint32`` words, high word first
    (:func:`jax._src.random.threefry2x32.threefry_seed`'s documented layout; a test keeps the two
    equal). ``jax.random.key`` traces and compiles two small programs in a new process (about
    0.05 s of CPU, 5 % of a warm ``fit``'s start-up); another implementation takes that path."""
    seed = int(seed)
    if str(jax.config.jax_default_prng_impl) != "threefry2x32" or not 0 <= seed < 2**63:
        return jax.random.key(seed)
    return jax.random.wrap_key_data(np.array([seed >> 32, seed & 0xFFFFFFFF], np.uint32))


def fit_polach(dataset, method: str, key, *, pop_size: int = 50, max_iter: int = 300, target=None):
    """:func:`jadhesion.identify.polach_fit.fit_polach` through a kept program (exported now on a
    miss). Returns a named tuple with :class:`~jadhesion.identify.polach_fit.PolachFit`'s fields
    (in alphabetical order), equal bit for bit to the library's result."""
    target = None if target is None else float(target)
    make = functools.partial(_polach_program, method, pop_size, max_iter, target)
    args = (dataset, jax.random.key_data(key))
    if not _enabled():
        out = make()(*args)
    else:
        static = {
            "method": method,
            "pop_size": int(pop_size),
            "max_iter": int(max_iter),
            "target": target,
            "prng": str(jax.random.key_impl(key)),
        }
        out = _kept("polach_fit", make, args, static)
    return _result_type(tuple(out))(**out)


def trust_numbers(params, dataset):
    """:func:`jadhesion.identify.trust.trust_numbers` (covariance and HAC bandwidth of a fit, the
    curve's peak and its gradient, the block jackknife's refits) through a kept program; a named tuple with
    :class:`~jadhesion.identify.trust.TrustNumbers`' fields (in alphabetical order), the same
    numbers bit for bit."""
    args = (jnp.asarray(params), dataset)
    out = _trust_program()(*args) if not _enabled() else _kept("polach_trust", _trust_program, args, {})
    return _result_type(tuple(out), "TrustNumbers")(**out)
