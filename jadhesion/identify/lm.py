"""Levenberg–Marquardt in jadhesion, one module per concern (this module re-exports them):

* :mod:`.lm_result` — :class:`LMResult` (params, sse, steps, success, status), ``best_of``;
* :mod:`.lm_optx` — optimistix LM with the sine map for bounds (:func:`lm_solve`, NIST, diagnosis);
* :mod:`.box_lm` — the projected box LM used for every Polach least-squares problem;
* :mod:`.lm_queue` — many box-LM problems as a work queue;
* :mod:`.global_lm` — seeded multi-start box LM.
"""

from .box_lm import GN_STEP, PROBE, BoxLMOptions, box_lm
from .global_lm import global_lm, seed_starts, with_start
from .lm_optx import from_box, lm_solve, multistart, safe_residual, to_box
from .lm_queue import box_lm_queue
from .lm_result import LMResult, best_of, sse_objective, status_code

__all__ = [
    "GN_STEP",
    "PROBE",
    "BoxLMOptions",
    "LMResult",
    "best_of",
    "box_lm",
    "box_lm_queue",
    "from_box",
    "global_lm",
    "lm_solve",
    "multistart",
    "safe_residual",
    "seed_starts",
    "sse_objective",
    "status_code",
    "to_box",
    "with_start",
]
