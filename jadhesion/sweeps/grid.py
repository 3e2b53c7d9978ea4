"""The declarative sweep grid, its canonical order, its chunks and its identity hash.

A grid point is ``(scenario, method, seed, noise_scale, creep_max)``. Points are ordered
scenario-major, then method, seed, noise_scale, creep_max (fastest), and each ``(scenario,
method)`` cell is cut into chunks of ``chunk_size`` consecutive points: one compiled shape per
method, the last chunk of a cell padded. Chunk ``i`` of the plan is the same work item on any
machine, so processes can share the plan by index and a rerun can skip finished chunks.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import NamedTuple, Optional

import numpy as np

from ..data.scenarios import SCENARIOS
from ..errors import InputError
from ..identify.polach_fit import METHODS


def _tuple(name, values, kind):
    values = (values,) if isinstance(values, (str, int, float)) else tuple(values)
    if not values:
        raise InputError(f"sweep grid: '{name}' is empty")
    if len(set(values)) != len(values):
        raise InputError(f"sweep grid: '{name}' has repeated values {list(values)}")
    try:
        return tuple(kind(v) for v in values)
    except (TypeError, ValueError) as exc:
        raise InputError(f"sweep grid: '{name}' must hold {kind.__name__} values: {exc}") from None


#: Fewest samples of a grid's simulated tests (``--samples``).
MIN_GRID_SAMPLES = 100
#: Largest noise scale of a grid point: 10× the simulator's μ̂ noise (0.1–0.2) is already the
#: size of the curve; ``1e300`` had run and reported "converged" fits.
MAX_NOISE_SCALE = 10.0


@dataclasses.dataclass(frozen=True)
class Grid:
    """The sweep's coordinates; their Cartesian product is the set of fits.

    Attributes:
        scenarios: simulated traction tests (names of :data:`jadhesion.data.scenarios.SCENARIOS`);
            a scenario fixes the true parameters and the simulated test.
        seeds: data seeds. Seed ``k`` simulates the scenario with :func:`simulate_batch` seed ``k``
            and starts the fit from key ``fold_in(key(k), method_salt(method))``, so every noise
            level and creep range of one seed sees the same noise realisation and fit key.
        methods: fitting methods of :func:`fit_polach` (``lm``, ``itlbo``, ``tlbo``, ``pso``).
        noise_scale: factor on the observation error around the true curve,
            ``mu_obs = curve + noise_scale · (mu_sim − curve)`` (1 = as simulated, 0 = noise-free).
        creep_max: the creep range covered by the test: only samples with ``|s| ≤ creep_max``
            are fitted (``inf`` = all samples); see :func:`jadhesion.sweeps.compute.observe`.
        n_samples: samples per simulated test (``None``: the simulator's default, 2000 = 40 s).
        fit_options: keyword arguments of :func:`fit_polach_batch` shared by every fit (budgets,
            target; hashable values), e.g. ``{"pop_size": 20, "max_iter": 100}``; kept as sorted
            pairs.
    """

    scenarios: tuple = ("dry", "wet", "sand")
    seeds: tuple = (0,)
    methods: tuple = ("lm",)
    noise_scale: tuple = (1.0,)
    creep_max: tuple = (math.inf,)
    n_samples: Optional[int] = None
    fit_options: tuple = ()

    def __post_init__(self):
        if self.n_samples is not None and int(self.n_samples) < MIN_GRID_SAMPLES:
            raise InputError(f"sweep grid: n_samples must be >= {MIN_GRID_SAMPLES}, got {self.n_samples}")
        options = dict(self.fit_options)
        try:
            hash(tuple(options.values()))
        except TypeError:
            raise InputError(f"sweep grid: fit_options values must be hashable, got {options}") from None
        object.__setattr__(self, "fit_options", tuple(sorted(options.items())))
        fields = {"scenarios": str, "seeds": int, "methods": str, "noise_scale": float, "creep_max": float}
        for name, kind in fields.items():
            object.__setattr__(self, name, _tuple(name, getattr(self, name), kind))
        known = tuple(SCENARIOS)
        for bad in (s for s in self.scenarios if s not in known):
            raise InputError(f"sweep grid: unknown scenario '{bad}' (known: {', '.join(known)})")
        for bad in (m for m in self.methods if m not in METHODS):
            raise InputError(f"sweep grid: unknown method '{bad}' (known: {', '.join(METHODS)})")
        if any(s < 0 for s in self.seeds):
            raise InputError("sweep grid: seeds must be non-negative")
        if any(not 0 <= x <= MAX_NOISE_SCALE for x in self.noise_scale):
            raise InputError(
                f"sweep grid: noise_scale must be in [0, {MAX_NOISE_SCALE:g}] (the simulator's "
                f"noise times it), got {self.noise_scale}"
            )
        if any(not x > 0 for x in self.creep_max):
            raise InputError(f"sweep grid: creep_max must be > 0, got {self.creep_max}")

    @property
    def size(self) -> int:
        """Number of fits."""
        return (
            len(self.scenarios)
            * len(self.methods)
            * len(self.seeds)
            * len(self.noise_scale)
            * len(self.creep_max)
        )

    @property
    def per_seed(self) -> int:
        """Points sharing one simulated dataset within a cell (noise levels × creep ranges)."""
        return len(self.noise_scale) * len(self.creep_max)

    def to_dict(self) -> dict:
        """The grid as plain JSON-ready values (its identity in :func:`grid_hash`)."""
        return dataclasses.asdict(self)


class Chunk(NamedTuple):
    """One work item: ``points[:, j]`` indexes ``grid.seeds``, ``noise_scale``, ``creep_max``."""

    index: int
    scenario: str
    method: str
    points: np.ndarray


def plan(grid: Grid, chunk_size: int) -> list:
    """The grid's chunks, in canonical order."""
    if chunk_size < 1:
        raise InputError(f"sweep: chunk size must be >= 1, got {chunk_size}")
    shape = (len(grid.seeds), len(grid.noise_scale), len(grid.creep_max))
    cell = np.stack(np.unravel_index(np.arange(math.prod(shape)), shape), axis=1)
    chunks = []
    for scenario in grid.scenarios:
        for method in grid.methods:
            for start in range(0, len(cell), chunk_size):
                chunks.append(Chunk(len(chunks), scenario, method, cell[start : start + chunk_size]))
    return chunks


def grid_hash(grid: Grid, chunk_size: int, source: str = "", code: str = "") -> str:
    """A digest of everything that determines the chunks' contents (names part files): the grid,
    the chunk size, ``source`` (names a non-default dataset source) and ``code`` (the
    :func:`.provenance.code_hash` of the code and runtime computing them)."""
    blob = json.dumps(
        {"grid": grid.to_dict(), "chunk_size": chunk_size, "source": source, "code": code}, sort_keys=True
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]
