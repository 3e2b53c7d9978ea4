"""The one registry of fitting methods: name → solver, defaults and what its counts mean.

Read by :func:`.polach_fit.fit_polach`, :func:`.curve_fit.curve_fit`, the Table 2 experiment,
the sweep grid and the CLI's ``--method`` choices (the CLI keeps a literal copy so that ``--help``
imports no JAX; a test checks it equals :data:`NAMES`).
"""

from __future__ import annotations

from typing import NamedTuple, Optional

from .population import Algorithm
from .pso import PSO
from .tlbo import ITLBO, TLBO


class Method(NamedTuple):
    """``name`` (CLI/JSON spelling), ``label`` (for people), ``algorithm`` (the population
    optimiser, ``None`` for LM), ``iterations`` (what the reported iteration count counts) and
    ``defaults`` (keyword defaults of :func:`.polach_fit.fit_polach` that apply)."""

    name: str
    label: str
    algorithm: Optional[Algorithm]
    iterations: str
    defaults: dict


_POP = {"pop_size": 50, "max_iter": 300}
#: Every method, in the CLI's order (the first is the default).
METHODS = {
    "itlbo": Method("itlbo", "improved TLBO (paper 001 §3.2)", ITLBO, "class iterations", _POP),
    "tlbo": Method("tlbo", "TLBO (Rao)", TLBO, "class iterations", _POP),
    "pso": Method("pso", "particle swarm (constriction)", PSO, "swarm iterations", _POP),
    "lm": Method(
        "lm",
        "global Levenberg–Marquardt (projected, box [0, 1]^5)",
        None,
        "LM steps, seeding and polish together",
        {},
    ),
}
#: Method names.
NAMES = tuple(METHODS)
#: The population optimisers by name.
POPULATION = {m.name: m.algorithm for m in METHODS.values() if m.algorithm is not None}


def check_method(name: str) -> Method:
    """The registered :class:`Method` called ``name``; ``ValueError`` naming the choices if none."""
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose one of {', '.join(NAMES)}")
    return METHODS[name]
