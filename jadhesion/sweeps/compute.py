"""One chunk of fits as a single jitted program on one device; chunks run side by side.

The unit of work is a whole chunk on one device: the vmapped observe → fit → peak program of
``chunk_size`` points (short chunks padded with copies of their last point). With ``D`` local
devices, ``D`` chunks are dispatched at once, one per device, and run concurrently (JAX's
asynchronous dispatch); no program is partitioned across devices. Every device therefore runs the
same compiled program on the same inputs for a given chunk, whatever the device count or process
split, and the table is the same bit for bit on 1, 2 or 4 devices and across processes. (A batch
sharded over the devices would change the per-device batch with the device count, and with it the
rounding of the vectorised program, which a population method amplifies.) Fit keys come from the
grid coordinates only.
"""

from __future__ import annotations

import functools
import zlib

import jax
import jax.numpy as jnp
import numpy as np

from ..identify.peak import reference_speed
from ..identify.polach_fit import MIN_SAMPLES, fit_polach_batch
from ..models.polach import adhesion_peak, polach_adhesion
from ..status import Status


def observe(data, theta_true, noise_scale, creep_max):
    """The dataset a fit sees at one grid point, with the number of samples it covers.

    * Noise: ``mu_obs = curve + noise_scale · (mu_sim − curve)`` with ``curve`` the true Polach curve
      at the samples, so the whole simulated observation error (sensor noise and observer error) is
      scaled.
    * Creep range: the samples with ``|s| ≤ creep_max`` are kept in their original order and
      repeated to the dataset's fixed length (each ⌊n/k⌋ or ⌈n/k⌉ times), so any fit sees them with
      near-equal weights and the shape never changes. If none qualifies, the smallest-creep sample
      stands alone.

    Returns:
        ``(dataset, covered)``: the transformed :class:`PolachDataset` and the count ``k`` of samples
        within the creep range.
    """
    curve = polach_adhesion(theta_true, data.creep, data.slip, data.k_eps)
    data = data._replace(adhesion=curve + noise_scale * (data.adhesion - curve))
    size = jnp.abs(data.creep)
    keep = size <= creep_max
    covered = jnp.sum(keep)
    n = size.shape[0]
    order = jnp.argsort(jnp.where(keep, 0.0, size), stable=True)
    pick = order[(jnp.arange(n) * jnp.maximum(covered, 1)) // n]
    return jax.tree.map(lambda a: a[pick] if a.ndim == 1 else a, data), covered


def method_salt(method: str) -> int:
    """A stable 31-bit integer naming a method, folded into its fit keys."""
    return zlib.crc32(method.encode()) & 0x7FFFFFFF


def fit_key(seed, method: str):
    """The fit key of a grid point: ``fold_in(key(seed), method_salt(method))``."""
    return jax.random.fold_in(jax.random.key(seed), method_salt(method))


def _local_chunk(method, options, data, theta_true, index, seed, noise_scale, creep_max):
    def prepare(i, ns, cm):
        d = jax.tree.map(lambda a: a[i], data)
        obs, covered = observe(d, theta_true, ns, cm)
        return obs, covered, reference_speed(d.vehicle_speed, d.weight), d.k_eps  # as fit reports its peak

    obs, covered, speed, k_eps = jax.vmap(prepare)(index, noise_scale, creep_max)
    keys = jax.vmap(lambda s: fit_key(s, method))(seed)
    fit = fit_polach_batch(obs, method, keys, **dict(options))
    peak = jax.vmap(adhesion_peak)
    true_mu_max, true_creep_opt = peak(jnp.broadcast_to(theta_true, fit.params.shape), k_eps, speed)
    mu_max, creep_opt = peak(fit.params, k_eps, speed)
    out = dict(
        samples=covered,
        params=fit.params,
        mae=fit.mae,
        iterations=fit.iterations,
        evaluations=fit.evaluations,
        true_mu_max=true_mu_max,
        true_creep_opt=true_creep_opt,
        mu_max=mu_max,
        creep_opt=creep_opt,
    )
    # jadhesion.status.Status codes; a creep range with fewer samples than a fit needs was fitted
    # to copies of its few samples and 'converged' (5 samples: μ0 0.81 for 0.36): not run, and
    # its numbers NaN (empty in the table), so that no aggregate takes them for a fit
    few = covered < MIN_SAMPLES
    out["status"] = jnp.where(few, int(Status.NOT_RUN), fit.status)
    for name in ("params", "mae", "mu_max", "creep_opt"):
        value = out[name]
        out[name] = jnp.where(few.reshape(few.shape + (1,) * (value.ndim - 1)), jnp.nan, value)
    return out


@functools.lru_cache(maxsize=None)
def _program(method: str, options: tuple):
    return jax.jit(functools.partial(_local_chunk, method, options))


def start_chunk(
    method: str, data, theta_true, index, seed, noise_scale, creep_max, *, size=None, options=(), device=None
) -> dict:
    """Dispatch one chunk of grid points to ``device``; returns its (not yet computed) outputs.

    Args:
        method: fitting method (static: one compiled program per method and shape).
        data: stacked :class:`PolachDataset` of the chunk's distinct seeds, leading axis ``u``.
        theta_true: true ``[kA, kS, mu0, A, B]`` of the scenario, shape (5,).
        index: per point, the row of ``data`` to use, shape (m,), int.
        seed, noise_scale, creep_max: per point grid coordinates, shape (m,).
        size: the batch length to compile for (default ``m``): the points are padded with copies of
            the last one to ``size``; :func:`finish_chunk` drops the padding.
        options: ``(name, value)`` pairs passed to :func:`fit_polach_batch` (static).
        device: where the chunk runs (default ``jax.local_devices()[0]``).

    Returns:
        The program's outputs as device arrays of length ``max(m, size)`` (JAX dispatches
        asynchronously: call this for one chunk per device, then :func:`finish_chunk` on each).
    """
    device = jax.local_devices()[0] if device is None else device
    m = len(index)
    take = np.concatenate([np.arange(m), np.full(max(m, size or 0) - m, m - 1)])
    per_point = [np.asarray(a)[take] for a in (index, seed, noise_scale, creep_max)]
    inputs = jax.device_put((data, jnp.asarray(theta_true), *per_point), device)
    return _program(method, tuple(options))(*inputs)


def finish_chunk(outputs: dict, m: int) -> dict:
    """Wait for a chunk started by :func:`start_chunk`; host NumPy arrays of its ``m`` points."""
    return {k: np.asarray(v)[:m] for k, v in outputs.items()}
