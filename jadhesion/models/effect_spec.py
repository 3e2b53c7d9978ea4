"""The shape of an effect's record in the registry (:data:`jadhesion.models.effects.EFFECTS`): what
the simulator, the diagnosis' extension, its explanation and its benchmarks know about one effect."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import NamedTuple, Optional


class Param(NamedTuple):
    """A parameter of an effect's extension (:mod:`jadhesion.diagnose.extensions`): its name, the
    fit's box ``[lower, upper]``, the ``neutral`` value at which the extension is the base model
    exactly, and its ``unit``; ``fold_fixed``: it places the effect in time, so a cross-validation
    fold whose held-out block contains that place cannot determine it (a flat direction: the fold's
    LM stalls or runs to its cap) — the folds keep it at the full-data fit's value;
    ``plausible_abs``: for a parameter other than the magnitude, the largest ``|value|`` the effect
    has (a fit beyond it is the base model's misfit, :meth:`EffectSpec.implausible`); ``None``: any
    value in the box."""

    name: str
    lower: float
    upper: float
    neutral: float
    unit: str
    fold_fixed: bool = False
    plausible_abs: Optional[float] = None


class Detection(NamedTuple):
    """A documented detection threshold (|magnitude| in the simulator's units; ``None``: not reached
    in the typical range): ``top1`` — named in ≥ 90 % of blind cases above it; ``in_set`` — the
    verdict or its indistinguishable set ≥ 90 %; ``note`` — the counts behind it, and how often
    the effect was named where its recording's own limit (``sensitivity.min_detectable``) said it
    could be seen (:data:`jadhesion.models.effects.DETECTION_PROVENANCE`)."""

    top1: Optional[float]
    in_set: Optional[float]
    note: str
    #: ``(named, above)``: of the blind cases (either generator) whose size reached their recording's
    #: own ``min_detectable``, how many were named, and how many there were
    #: (:data:`jadhesion.models.effects.OWN_LIMIT_PROVENANCE`).
    own_limit: tuple = (0, 0)

    def limit_holds(self) -> Optional[bool]:
        """Whether the recording's own limit has held (named in ≥ 90 % of the blind cases above it);
        None where no blind case reached it."""
        named, above = self.own_limit
        return None if above == 0 else named >= 0.9 * above


def _no_terms(values: Mapping) -> dict:
    return {}


#: A fitted |magnitude| beyond this multiple of the top of the effect's ``typical`` range is taken
#: for the base model's misfit, not the effect (:meth:`EffectSpec.plausible`). On the independent
#: generator's clean recordings 7 of the 9 effects the null let through were such sizes: a μ0 rising
#: 51–150 % in the first 2.7–4.8 s of a start (walking pace, where the errors-in-variables misfit
#: is largest), a 91 % drop mid-sweep, a torque offset of 0.16 (seeds 11 and 31 of
#: ``benchmarks/diagnose_null.py``); its concealed effects stay within the typical ranges.
IMPLAUSIBLE_BEYOND = 1.5


class EffectSpec(NamedTuple):
    """One effect's record.

    Simulator: ``factor`` (its law, naming the pure function of :mod:`jadhesion.models.effects`
    that applies it), ``default``/``low``/``high`` (default magnitude and allowed interval), ``unit``,
    ``summary`` (one line). Diagnosis: ``extension`` (its :class:`Param` s, the first estimating the
    simulator's magnitude), ``typical`` (the log-uniform |magnitude| range of blind cases and of
    "visible at typical magnitudes"), ``signed`` (the sign is drawn at random), ``signal`` (the
    signal its residual signature follows, a :func:`jadhesion.diagnose.features.library` key),
    ``exposing_run`` (the run that exposes it when a recording cannot), ``separating`` (neighbour →
    the run that separates the two; each pair is written once, in the record of the effect that
    comes first in the registry), ``sentence`` and ``terms`` (the explanation: a :meth:`str.format`
    template over the fitted parameters, the vehicle's ``wheel_radius_m``, ``axle_load_kg`` and
    ``gravity``, and the derived ``terms``), ``detection`` (:class:`Detection`), ``extra_starts``
    (further starts of ``start_param``, by default the magnitude parameter, where its fit from the
    recording's starting value can end in a wrong local minimum; the best converged fit is kept),
    ``grid_params`` (parameters picked on a grid before the fit, e.g. a time constant: counted in
    BIC beside the fitted ones).
    """

    name: str
    factor: str
    default: float
    low: float
    high: float
    unit: str
    summary: str
    extension: tuple
    typical: tuple
    signed: bool
    signal: str
    exposing_run: str
    separating: dict
    sentence: str
    detection: Detection
    terms: Callable[[Mapping], dict] = _no_terms
    extra_starts: tuple = ()
    start_param: str = ""
    grid_params: int = 0

    @property
    def params(self) -> tuple:
        """The extension's parameter names."""
        return tuple(p.name for p in self.extension)

    @property
    def magnitude_param(self) -> str:
        """The extension parameter that estimates the simulator's magnitude."""
        return self.extension[0].name

    def plausible(self, magnitude: float) -> bool:
        """Whether a fitted ``magnitude`` (of :attr:`magnitude_param`) is one the effect has: within
        :data:`IMPLAUSIBLE_BEYOND` × the top of its typical range."""
        return not self.implausible({self.magnitude_param: magnitude})

    def implausible(self, values: Mapping) -> dict:
        """``{parameter: limit}`` of the fitted extension parameters in ``values`` beyond what the
        effect has: the magnitude beyond :data:`IMPLAUSIBLE_BEYOND` × the top of its typical range,
        another parameter beyond its :attr:`Param.plausible_abs`. Empty for a fit the effect can
        make."""
        limits = {self.magnitude_param: IMPLAUSIBLE_BEYOND * self.typical[1]}
        limits.update({p.name: p.plausible_abs for p in self.extension[1:] if p.plausible_abs is not None})
        return {k: lim for k, lim in limits.items() if k in values and not abs(values[k]) <= lim}

    @property
    def extra_start_param(self) -> str:
        """The parameter :attr:`extra_starts` are values of."""
        return self.start_param or self.magnitude_param

    def explain(self, values: Mapping) -> str:
        """The explanation sentence from the fitted parameters and the vehicle (class docstring)."""
        return self.sentence.format_map({**values, **self.terms(values)})
