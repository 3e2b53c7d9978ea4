"""Many datasets, one compiled program per method and length bucket: padding and masks.

A dataset of ``n`` samples is padded to its *bucket* length
(:func:`jadhesion.data.length_buckets.bucket_length`: 128 for ``n ≤ 128``, the next power of two
up to 16 384 samples, then the next eighth of an octave) by repeating its last sample, with a ``weight`` mask
(1 for its samples, 0 for the padding; :class:`jadhesion.data.dataset.PolachDataset`). The Polach
objective honours the mask (:func:`jadhesion.identify.polach_residuals.polach_residual` multiplies the
residual by it, the MAE divides by the number of valid samples, the LM's seeding subsample strides
over the valid samples only), so a padded fit solves the same problem as the unpadded one and
every dataset of a bucket reuses the bucket's compiled program (and, in the command line, its kept
exported program).

**The same answer as one file at a time.** :func:`fit_datasets` fits each padded dataset with the
same single-dataset program and the same key as ``jadhesion fit FILE`` — so the command's results
for a file do not depend on which other files are in the call. ``tests/test_multifile.py`` checks
that the padded fit equals the unpadded one: the population methods (improved TLBO, TLBO, PSO)
give bit-identical parameters (their moves depend on the data only through comparisons of MAEs,
which the padding changes by at most an ulp), LM agrees to round-off (≈1e-12 relative; its
normal equations sum over a different length). :func:`fit_datasets_vmapped` instead stacks each
bucket and runs :func:`.polach_fit.fit_polach_batch` (one vmapped program per bucket). Its
rounding depends on the batch (see the tests for the agreement), and on CPU it is the slower of
the two with LM's errors-in-variables residual (``benchmarks/bench_multifile.py``).
"""

from __future__ import annotations

import time
from typing import Callable, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import SAMPLE_FIELDS, PolachDataset, valid_mask
from ..data.length_buckets import bucket_length

# No module-level import of the fits (:mod:`.polach_fit` pulls in optimistix/equinox): the
# command line's warm start, which calls a kept program, must not import them.


def pad_dataset(data: PolachDataset, length: int | None = None) -> PolachDataset:
    """``data`` padded to ``length`` samples (default :func:`bucket_length`) by repeating its
    last sample, with ``weight`` 1 on its own samples and 0 on the padding."""
    if data.weight is not None:
        raise ValueError("pad_dataset: the dataset is already padded (it has a weight)")
    n = int(data.adhesion.shape[-1])
    length = bucket_length(n) if length is None else int(length)
    if length < n:
        raise ValueError(f"pad_dataset: length {length} < {n} samples")
    extra = length - n

    def pad(a):
        if a is None:
            return None
        return jnp.pad(jnp.asarray(a), [(0, extra)] + [(0, 0)] * (jnp.ndim(a) - 1), mode="edge")

    fields = {f: pad(getattr(data, f)) for f in SAMPLE_FIELDS}
    weight = np.zeros(length, jnp.result_type(data.adhesion))
    weight[:n] = 1.0
    return data._replace(**fields, weight=jnp.asarray(weight))


def bucketed(data: PolachDataset) -> PolachDataset:
    """``data`` padded to its length bucket (:func:`pad_dataset`), or as it is when it has a
    ``weight`` (padded already): what the fit and its trust block compute on, one compiled program
    per bucket."""
    return data if data.weight is not None else pad_dataset(data)


def valid_samples(data: PolachDataset) -> int:
    """Number of samples that count (:func:`valid_mask`)."""
    return int(np.sum(valid_mask(data)))


class Fitted(NamedTuple):
    """One dataset's result: the fit (a :class:`.polach_fit.PolachFit` or the kept program's
    equal named tuple; ``mae``/``sse`` over the valid samples) and the seconds it took (the
    bucket's compilation is charged to the first dataset of the bucket)."""

    fit: NamedTuple
    seconds: float


def fit_datasets(
    datasets: Sequence[PolachDataset],
    method: str,
    key,
    *,
    pop_size: int = 50,
    max_iter: int = 300,
    fit: Callable | None = None,
) -> list[Fitted]:
    """Fit every dataset, padded to its bucket, with the same ``key`` (as one file at a time);
    ``fit`` is :func:`.polach_fit.fit_polach` (default), a drop-in (the command line's kept
    program, :func:`jadhesion.cli.fit_program.fit_polach`) or :func:`.kiencke_fit.fit_kiencke`
    (its informative samples exclude the padding). One compiled program per method and bucket."""
    if fit is None:
        from .polach_fit import fit_polach as fit
    out = []
    for data in datasets:
        padded = pad_dataset(data)
        start = time.perf_counter()
        result = jax.block_until_ready(fit(padded, method, key, pop_size=pop_size, max_iter=max_iter))
        out.append(Fitted(result, time.perf_counter() - start))
    return out


def buckets(datasets: Sequence[PolachDataset]) -> dict:
    """``{(bucket length, pytree structure): [indices]}`` — datasets that stack together."""
    groups: dict = {}
    for i, data in enumerate(datasets):
        padded_like = data._replace(weight=0.0)
        key = (bucket_length(int(data.adhesion.shape[-1])), jax.tree.structure(padded_like))
        groups.setdefault(key, []).append(i)
    return groups


def fit_datasets_vmapped(
    datasets: Sequence[PolachDataset], method: str, key, *, pop_size: int = 50, max_iter: int = 300
) -> list:
    """Fit every dataset, stacked per bucket, with one vmapped program per method and bucket
    (:func:`.polach_fit.fit_polach_batch`; the same ``key`` for every dataset). Agrees with
    :func:`fit_datasets` to round-off, not bit for bit (the batch changes XLA's reductions)."""
    from .polach_fit import fit_polach_batch

    results: list = [None] * len(datasets)
    for (length, _), idx in buckets(datasets).items():
        stacked = jax.tree.map(lambda *a: jnp.stack(a), *[pad_dataset(datasets[i], length) for i in idx])
        keys = jnp.stack([key] * len(idx))
        batch = jax.block_until_ready(
            fit_polach_batch(stacked, method, keys, pop_size=pop_size, max_iter=max_iter)
        )
        for j, i in enumerate(idx):
            results[i] = jax.tree.map(lambda a, j=j: a[j], batch)
    return results
