"""The peak of a fitted Polach curve, μ_max and creep_opt, with delta-method intervals.

What a traction controller needs from a fit is where the curve peaks: the largest adhesion
``mu_max`` [-] and the creepage ``creep_opt`` [-] at which it is reached
(:func:`jadhesion.models.polach.adhesion_peak`), at a reference speed, the median ``|v|`` of the
fitted samples (:func:`reference_speed`; friction falls with the slip velocity ``w = s·v``, so the
peak depends on the speed). Their uncertainty follows from the fit's covariance ``Σ`` (the HAC
sandwich of :mod:`.trust`) by the delta method, ``Var g(θ) ≈ ∇g Σ ∇gᵀ``, with the gradient of the
peak search itself (its parabolic refinement is differentiable). ``mu_max``'s 95 % interval is
``± 1.96 sd`` within [0, :data:`MU_BOX_MAX`] (the largest adhesion of any curve in the box);
``creep_opt``, a positive scale, gets its interval on the log scale, ``creep_opt · exp(± 1.96
sd_log)`` within the searched range (``stderr`` = ``creep_opt · sd_log``). A standard error the
data do not determine (:func:`.uncertainty.determined`: infinite, where the peak depends on a
singular direction of the fit, or wider than its box, [0, :data:`MU_BOX_MAX`] for ``mu_max``,
``ln(S_MAX/S_MIN)`` for ``creep_opt``'s ``sd_log``) is ``null`` with no interval, and the quantity is
named in an ``undetermined`` warning.

Warning ``peak_extrapolated``: ``creep_opt`` lies outside the creep the recording covers, on either
side — its creep never reaches the peak (extrapolated from the rising branch) or never comes down to
it (from the falling branch): the interval is the model's, not the data's — or the curve has no
peak below creep :data:`S_MAX` (``mu_max`` is its value there; ``creep_opt`` has no interval).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..models.polach import adhesion_peak
from .uncertainty import UNDETERMINED, Z95, determined, normal_interval, undetermined_warning

#: The creep range [-] searched for the peak (:func:`adhesion_peak`'s defaults).
S_MIN, S_MAX = 1e-5, 1.0
#: A creep_opt within this factor of an end of the range counts as on it (no interior peak).
EDGE = 1.05
DERIVED = ("mu_max", "creep_opt")
#: Largest adhesion of any Polach curve in the unit box: μ ≤ μ0 ≤ 1 and
#: ``kA ε/(1 + (kA ε)²) + atan(kS ε) < 1/2 + π/2``, so ``μ_adh < 1 + 1/π``.
MU_BOX_MAX = 1.0 + 1.0 / np.pi
#: Width of the searched creep range on the log scale, creep_opt's box for ``sd_log``.
LOG_WIDTH = float(np.log(S_MAX / S_MIN))


def reference_speed(vehicle_speed, weight=None):
    """Median ``|v|`` [m/s] of the samples (those with ``weight`` > 0 when a padding mask is
    given): the speed at which :func:`peak_numbers` evaluates the peak."""
    speed = jnp.abs(vehicle_speed)
    if weight is not None:
        speed = jnp.where(weight > 0, speed, jnp.nan)
    return jnp.nanmedian(speed)


def peak_numbers(theta, k_eps, speed):
    """``(peak, jacobian)``: ``(mu_max, creep_opt)`` (2,) of ``theta`` (5,) at ``speed`` [m/s] and
    their gradient (2, 5). Pure and traceable."""

    def peak(th):
        return jnp.stack(adhesion_peak(th, k_eps, speed, s_min=S_MIN, s_max=S_MAX))

    return peak(theta), jax.jacfwd(peak)(theta)


def _variance(grad, cov):
    """``grad Σ gradᵀ``, with ``inf`` where a parameter the quantity depends on has an unbounded
    variance (a singular direction of the fit)."""
    used = np.abs(grad) > 0
    sub = cov[np.ix_(used, used)]
    if not np.all(np.isfinite(sub)):
        return np.inf
    with np.errstate(over="ignore", invalid="ignore"):
        var = grad[used] @ sub @ grad[used]
    return float(max(var, 0.0)) if np.isfinite(var) else np.inf


def peak_report(
    peak, jacobian, cov, speed, max_creep, min_creep=0.0, jackknife=(0.0, 0.0)
) -> tuple[dict, list]:
    """``(derived, warnings)`` of a fit: ``derived`` {``mu_max``, ``creep_opt``: {``value``,
    ``stderr``, ``ci95``, ``stderr_hac``, ``stderr_jackknife``}} from :func:`peak_numbers`' ``peak``
    and ``jacobian``, the fit's ``cov`` (5, 5), the reference ``speed`` [m/s] and the largest and
    smallest ``|creep|`` of the fitted samples; ``stderr`` is the larger of the delta method's
    (``stderr_hac``) and the block jackknife's ``jackknife`` (sd of ``mu_max`` and of
    ``log creep_opt``; :func:`.trust.trust_numbers`);
    ``warnings`` as in :mod:`.trust` (module docstring), with ``undetermined`` for a quantity whose
    standard error is not determined."""
    mu_max, creep_opt = (float(x) for x in np.asarray(peak))
    jac, cov = np.asarray(jacobian, float), np.asarray(cov, float)
    cov = np.where(np.isnan(cov), 0.0, cov)  # a fixed parameter (nan) adds nothing; inf stays inf
    hac_mu = np.sqrt(_variance(jac[0], cov))
    sd_mu = max(hac_mu, jackknife[0])
    edge = creep_opt >= S_MAX / EDGE or creep_opt <= S_MIN * EDGE
    ci_mu = normal_interval(mu_max, sd_mu, Z95, 0.0, MU_BOX_MAX)
    derived = {"mu_max": _entry(mu_max, sd_mu, ci_mu, determined(sd_mu, MU_BOX_MAX), (hac_mu, jackknife[0]))}
    undetermined = [] if derived["mu_max"]["stderr"] is not None else ["mu_max"]
    if edge:
        derived["creep_opt"] = {"value": creep_opt, **UNDETERMINED}
    else:
        hac_log = np.sqrt(_variance(jac[1] / creep_opt, cov))
        sd_log = max(hac_log, jackknife[1])
        ci = normal_interval(creep_opt, sd_log, Z95, S_MIN, S_MAX, log=True)  # in the searched range
        parts = (creep_opt * hac_log, creep_opt * jackknife[1])
        derived["creep_opt"] = _entry(creep_opt, creep_opt * sd_log, ci, determined(sd_log, LOG_WIDTH), parts)
        undetermined += [] if derived["creep_opt"]["stderr"] is not None else ["creep_opt"]
    warnings = [undetermined_warning(undetermined)] if undetermined else []
    if edge:
        message = (
            f"the fitted curve has no peak at creep {S_MIN:g}–{S_MAX:g} at {speed:.3g} m/s: "
            f"mu_max is its value at creep {creep_opt:.3g}, creep_opt has no interval"
        )
        warnings.append({"code": "peak_extrapolated", "params": list(DERIVED), "message": message})
    elif (
        outside := extrapolation_warning(creep_opt, min_creep, max_creep, f" at {speed:.3g} m/s")
    ) is not None:
        warnings.append(outside)
    return derived, warnings


def extrapolation_warning(creep_opt, min_creep, max_creep, where="") -> dict | None:
    """``peak_extrapolated`` when a curve's ``creep_opt`` [-] lies outside the ``|creep|`` the data
    cover (``min_creep``–``max_creep``): its peak is then extrapolated from the rising (or falling)
    branch; ``where`` qualifies the peak in the message (e.g. the reference speed). ``None``
    otherwise (fit and ``online`` both use it)."""
    if min_creep <= creep_opt <= max_creep:
        return None
    side, bound, branch = (
        ("below", f"at most {max_creep:.3g}", "rising")
        if creep_opt > max_creep
        else ("above", f"at least {min_creep:.3g}", "falling")
    )
    message = (
        f"the recording's creep stays {side} the fitted curve's peak ({bound} against creep_opt "
        f"{creep_opt:.3g}{where}): mu_max and creep_opt are extrapolated from the {branch} branch"
    )
    return {"code": "peak_extrapolated", "params": list(DERIVED), "message": message}


def _entry(value, sd, ci, ok, parts):
    """A derived quantity's entry; ``parts``: its delta-method and jackknife standard errors."""
    if not ok:  # not determined: no number that would pretend otherwise
        return {"value": value, **UNDETERMINED}
    hac, jackknife = (float(x) for x in parts)
    return {
        "value": value,
        "stderr": float(sd),
        "ci95": [float(ci[0]), float(ci[1])],
        "stderr_hac": hac,
        "stderr_jackknife": jackknife,
    }
