"""Fitting datasets (:class:`~.dataset.PolachDataset`) of simulated recordings: from a
:class:`~.simulator.SimulationResult`, or straight from the simulator for a batch of seeds."""

from __future__ import annotations

from typing import Sequence

import jax
import jax.numpy as jnp

from .dataset import PolachDataset
from .simulator import SimulationResult, padded_seeds, simulate_arrays
from .vehicle import LOCO_22E, Vehicle


def _dataset(columns, k_eps) -> PolachDataset:
    return PolachDataset(
        creep=columns["creepage"],
        slip=columns["slip_velocity"],
        adhesion=columns["adhesion"],
        vehicle_speed=columns["vehicle_speed"],
        k_eps=k_eps,
    )


def result_dataset(result: SimulationResult) -> PolachDataset:
    """The fitting dataset of a simulated recording (recorded creep, slip, speed, observer output)."""
    return _dataset(
        {k: jnp.asarray(v) for k, v in result.columns.items()}, jnp.asarray(result.truth["k_eps"])
    )


def stack_datasets(results: Sequence[SimulationResult]) -> PolachDataset:
    """:func:`result_dataset` of several recordings of one length, stacked on a leading axis."""
    return jax.tree_util.tree_map(lambda *a: jnp.stack(a), *map(result_dataset, results))


def simulate_dataset(
    scenario,
    seed: int = 0,
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    sensors="realistic",
    sensor_noise: float = 1.0,
) -> PolachDataset:
    """The fitting dataset (recorded creep, slip, speed and observer output) of one recording."""
    data = simulate_batch(
        scenario,
        padded_seeds([seed]),
        effects,
        n_samples,
        vehicle=vehicle,
        sensors=sensors,
        sensor_noise=sensor_noise,
    )  # padded: one program for every single recording and small batch of simulate_many
    return jax.tree_util.tree_map(lambda a: a[0], data)


def simulate_batch(
    scenario,
    seeds: Sequence[int],
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    sensors="realistic",
    sensor_noise: float = 1.0,
) -> PolachDataset:
    """Datasets for many seeds in one vmapped, jitted call: every field gains a leading seed axis
    (``k_eps`` too, shape (n_seeds,)), so the result vmaps straight into a fit. Creep and slip are
    the raw differences of the recorded speeds (:func:`.dataset.to_dataset` smooths them). One
    program per number of seeds: pad a varying count with :func:`.simulator.padded_seeds` (a
    sweep's chunks have a fixed count)."""
    _, _, c, columns, _, _ = simulate_arrays(
        scenario, seeds, effects, n_samples, vehicle, True, sensors, sensor_noise
    )
    return _dataset(columns, jnp.full((len(seeds),), c["k_eps"]))
