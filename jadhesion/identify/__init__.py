"""Offline identification: population optimisers (TLBO, improved TLBO, PSO), one driver, LM, curve_fit
and the Polach fit built on them."""

from .curve_fit import CurveFitResult, covariance, curve_fit
from .driver import History, RunResult, iteration_key, run, run_until
from .lm import LMResult, global_lm, lm_solve, multistart
from .methods import METHODS, NAMES, POPULATION, Method
from .polach_fit import PolachFit, fit_polach, fit_polach_batch
from .polach_residuals import polach_mae, polach_residual
from .population import Algorithm, StepInfo
from .pso import PSO, PSOParams, PSOState
from .tlbo import ITLBO, TLBO, TLBOParams, TLBOState

#: The population optimisers by name (the registry's :data:`.methods.POPULATION`).
ALGORITHMS = POPULATION

__all__ = [
    "ALGORITHMS",
    "Algorithm",
    "CurveFitResult",
    "History",
    "ITLBO",
    "LMResult",
    "METHODS",
    "Method",
    "NAMES",
    "POPULATION",
    "PSO",
    "PSOParams",
    "PSOState",
    "PolachFit",
    "RunResult",
    "StepInfo",
    "TLBO",
    "TLBOParams",
    "TLBOState",
    "covariance",
    "curve_fit",
    "fit_polach",
    "fit_polach_batch",
    "global_lm",
    "iteration_key",
    "lm_solve",
    "multistart",
    "polach_mae",
    "polach_residual",
    "run",
    "run_until",
]
