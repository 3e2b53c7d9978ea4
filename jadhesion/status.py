"""One result status for every solver, fit and estimate in jadhesion.

Inside jitted code a status is an ``int32`` array (one per fit, so batches vmap); at the boundary it
becomes the :class:`Status` member and its lower-case name (``"converged"``, ``"max_steps"``, …),
which is what JSON documents and tables carry. A result is never reported without its status, and a
status other than :attr:`Status.CONVERGED` is never shown as a success.
"""

from __future__ import annotations

import enum

import numpy as np


class Status(enum.IntEnum):
    """Why a solver stopped.

    * ``CONVERGED`` — its convergence test passed (LM: MINPACK's ftol/xtol/gtol tests; population
      methods: the documented stall-and-spread test or a target reached; RLS: ran to the end with a
      finite, well-conditioned information matrix).
    * ``MAX_STEPS`` — the iteration or step cap was reached before the test passed.
    * ``STALLED`` — no decrease could be made (LM's damping overflowed) without the test passing.
    * ``NONFINITE`` — the objective, the parameters or the estimate became NaN or infinite.
    * ``SINGULAR`` — the result exists but its covariance or normal matrix is singular.
    * ``NOT_RUN`` — nothing was computed (e.g. too few samples); never returned by a solver.
    """

    CONVERGED = 0
    MAX_STEPS = 1
    STALLED = 2
    NONFINITE = 3
    SINGULAR = 4
    NOT_RUN = 5

    @property
    def label(self) -> str:
        """The JSON/table spelling, e.g. ``"max_steps"``."""
        return self.name.lower()

    @property
    def converged(self) -> bool:
        return self is Status.CONVERGED


def status_of(code) -> Status:
    """The :class:`Status` of a scalar status code (Python int, NumPy or JAX scalar)."""
    return Status(int(np.asarray(code)))


def status_labels(codes) -> list[str]:
    """Lower-case status names of an array of codes (any shape, flattened)."""
    return [Status(int(c)).label for c in np.asarray(codes).ravel()]
