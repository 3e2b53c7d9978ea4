"""Helper for tests/test_sweep.py: a cheap dataset source and a sweep run in a fresh process.

    python tests/_sweep_worker.py OUT [--chunk-size N] [--coordinator HOST:PORT --num-processes P
                                                         --process-id I]

Prints the run's summary as one JSON line. Forced device counts come from the caller's
``XLA_FLAGS``; the persistent compilation cache from ``JADHESION_CACHE``. jadhesion is imported
only after ``jax.distributed.initialize`` (importing it creates arrays, which starts the backend).
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp

K_EPS = 130.0


def toy_grid():
    """The tiny grid every sweep test runs: 2 scenarios × 3 seeds × 2 noise × 2 creep ranges."""
    from jadhesion.sweeps import Grid

    return Grid(
        scenarios=("dry", "sand"),
        seeds=(0, 1, 5),
        methods=("pso",),
        noise_scale=(0.5, 2.0),
        creep_max=(0.05, float("inf")),
        fit_options={"pop_size": 12, "max_iter": 15},
    )


@jax.jit
def _toy(theta, max_creep, speed, seeds):
    from jadhesion.data.dataset import PolachDataset
    from jadhesion.models.polach import polach_adhesion

    def one(seed):
        k1, k2 = jax.random.split(jax.random.key(seed))
        creep = jnp.exp(jax.random.uniform(k1, (120,), minval=jnp.log(0.002), maxval=jnp.log(max_creep)))
        slip = creep * speed
        mu = polach_adhesion(theta, creep, slip, K_EPS) + 0.01 * jax.random.normal(k2, (120,))
        return PolachDataset(creep, slip, mu, jnp.full_like(creep, speed), jnp.asarray(K_EPS))

    return jax.vmap(one)(seeds)


def toy_simulate(grid, scenario, seeds):
    """Polach curve of the scenario's true parameters + 0.01 Gaussian noise, 120 log-spaced creeps."""
    from jadhesion.data.scenarios import SCENARIOS

    s = SCENARIOS[scenario]
    return _toy(jnp.asarray(s.params), s.max_creep, s.mean_speed, jnp.asarray(seeds))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("out")
    parser.add_argument("--chunk-size", type=int, default=5)
    parser.add_argument("--coordinator")
    parser.add_argument("--num-processes", type=int)
    parser.add_argument("--process-id", type=int)
    args = parser.parse_args()
    if args.coordinator:
        jax.distributed.initialize(args.coordinator, args.num_processes, args.process_id)
    from jadhesion.config import enable_compilation_cache, enable_x64
    from jadhesion.sweeps import run_sweep

    enable_x64()
    enable_compilation_cache()
    _, summary = run_sweep(toy_grid(), args.out, chunk_size=args.chunk_size, simulate=toy_simulate)
    print(json.dumps(summary._asdict()))
    if args.coordinator:
        jax.distributed.shutdown()


if __name__ == "__main__":
    main()
