"""The one covariance routine of jadhesion, and the trust report of a Polach fit.

At a least-squares optimum with residuals ``r`` (n,) and Jacobian ``J = ∂r/∂θ`` (n, d):

* **i.i.d.** (scipy's ``curve_fit``): ``Cov = s² (JᵀJ)⁺``, ``s² = SSE/(n − d)``.
* **HAC sandwich** (Newey–West 1987): ``Cov = n/(n − d) · (JᵀJ)⁺ S (JᵀJ)⁺`` with
  ``S = Γ₀ + Σ_{l=1..L} (1 − l/(L+1)) (Γ_l + Γ_lᵀ)``, ``Γ_l = Σ_t g_t g_{t−l}ᵀ``, ``g_t = J_t r_t``.
  The observer low-pass filters the noise, so neighbouring residuals are correlated and the i.i.d.
  formula understates the error; the sandwich does not assume independence. Rows must be in time
  order. Bandwidth ``L`` (Andrews 1991, Bartlett kernel, AR(1) plug-in): with ``ρ`` the lag-1
  autocorrelation of ``r`` (clipped to ±0.97), ``α = 4ρ²/((1 − ρ)²(1 + ρ)²)``,
  ``L = ⌈1.1447 (α n)^{1/3}⌉`` (at most ``n − 1``). The autocovariances come from one FFT per pair
  of columns, so every lag costs ``O(n log n)``.

The pseudo-inverse is taken through the SVD of the column-equilibrated Jacobian ``J D⁻¹``
(``D`` the column norms); singular values below :data:`RCOND` times the largest are dropped, and
every parameter with a component in a dropped direction gets an **infinite** variance (rows and
columns ``inf``): a singular covariance is reported as such, never as finite garbage. A parameter
flagged ``fixed`` (e.g. sitting on a bound) is left out: its row and column are ``nan``, the others
are conditional on it.

**Not determined** (:func:`determined`): a standard error that is not finite (a dropped direction),
or larger than the width of the quantity's whole admissible range (its box: 1 for a Polach
parameter), says that the data bound the quantity less than the box alone does; reports give it
no standard error and no interval (``null``) and name it in an ``undetermined`` warning
(:func:`undetermined_warning`), never an ``inf`` or a 10¹⁵⁴.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .small_linalg import svd_tall

#: Relative singular value of the equilibrated Jacobian below which a direction counts as
#: undetermined (its variance would exceed the best-determined one's by 10¹⁸).
RCOND = 1e-9
#: Two-sided 95 % and 90 % normal quantiles.
Z95, Z90 = 1.959963984540054, 1.6448536269514722
#: A fit's undetermined (or held) quantity's numbers: every key a determined one has, null.
UNDETERMINED = dict.fromkeys(("stderr", "ci95", "stderr_hac", "stderr_jackknife"))


def normal_interval(value, sd, z, lo, hi, log=False) -> list:
    """``[value − z·sd, value + z·sd]`` clipped to ``[lo, hi]``; with ``log``, ``exp(log value ±
    z·sd)`` with ``sd`` that of ``log value``, clipped likewise (floats)."""
    if log:
        c = np.log(value)
        return [float(np.exp(max(c - z * sd, np.log(lo)))), float(np.exp(min(c + z * sd, np.log(hi))))]
    return [float(max(value - z * sd, lo)), float(min(value + z * sd, hi))]


def determined(sd, width=1.0) -> bool:
    """Whether a standard error ``sd`` means something for a quantity whose box is ``width`` wide:
    finite and at most ``width`` (module docstring)."""
    return bool(np.isfinite(sd) and sd <= width)


def block_jackknife_sd(replicates) -> np.ndarray:
    """Delete-a-block jackknife standard errors (P,) from ``replicates`` (B, P), the estimates
    refitted without each of B blocks in turn: ``√((B − 1)/B · Σ (x_b − x̄)²)`` (NaN where a
    replicate is not finite)."""
    x = np.asarray(replicates, float)
    b = x.shape[0]
    return np.sqrt((b - 1) / b * np.sum((x - x.mean(axis=0)) ** 2, axis=0))


def undetermined_warning(names) -> dict:
    """The ``undetermined`` warning ``{code, params, message}`` naming the quantities whose
    standard error is not :func:`determined`."""
    names = list(names)
    return {
        "code": "undetermined",
        "params": names,
        "message": (
            f"{', '.join(names)}: not determined by the data (a singular direction of the fit, or a "
            "standard error wider than the whole box): no standard error or interval (null)"
        ),
    }


def lag1_autocorrelation(r):
    """``Σ r_t r_{t−1} / Σ r_t²`` of residuals ``r`` (n,) in time order (0 when all are 0)."""
    return jnp.sum(r[1:] * r[:-1]) / jnp.maximum(jnp.sum(r * r), jnp.finfo(r.dtype).tiny)


def bandwidth(r, n=None):
    """Newey–West lag truncation ``L`` from the residuals (Andrews' AR(1) plug-in, see above);
    ``n`` the number of samples that count (default all; padding rows are zero residuals)."""
    n = r.shape[0] if n is None else n
    rho = jnp.clip(lag1_autocorrelation(r), -0.97, 0.97)
    alpha = 4 * rho**2 / ((1 - rho) ** 2 * (1 + rho) ** 2)
    return jnp.minimum(jnp.ceil(1.1447 * (alpha * n) ** (1.0 / 3.0)), n - 1)


def _long_run(g, lags):
    """``S = Σ_l w_l Γ_l`` over all lags with Bartlett weights ``w_l = max(0, 1 − |l|/(L+1))``."""
    n, d = g.shape
    size = 2 * n
    spec = jnp.fft.rfft(g, n=size, axis=0)  # (size/2+1, d)
    cross = jnp.fft.irfft(spec[:, :, None] * jnp.conj(spec[:, None, :]), n=size, axis=0)
    lag = jnp.fft.fftfreq(size, 1.0 / size)  # 0, 1, …, n−1, −n, …, −1
    w = jnp.maximum(0.0, 1.0 - jnp.abs(lag) / (lags + 1.0))
    return jnp.einsum("l,lij->ij", w, cross)


@functools.partial(jax.jit, static_argnames=("hac",))
def covariance(jac, r, fixed=None, hac=True, weight=None):
    """Covariance (d, d) of the least-squares parameters from ``jac`` (n, d) and ``r`` (n,);
    ``fixed`` (d,) bool leaves parameters out (``nan``); ``hac`` selects the sandwich (else
    i.i.d.); ``weight`` (n,) a padding mask (0 on padded rows, whose ``jac`` and ``r`` must be 0):
    only its nonzero rows count in ``n``. Returns ``(cov, lags)`` — ``lags`` the bandwidth used
    (0 for i.i.d.)."""
    d = jac.shape[1]
    n = jac.shape[0] if weight is None else jnp.sum(weight > 0)
    fixed = jnp.zeros(d, bool) if fixed is None else fixed
    jac = jnp.where(fixed[None], 0.0, jac)
    scale = jnp.sqrt(jnp.sum(jac * jac, axis=0))
    scale = jnp.where(scale > 0, scale, 1.0)
    sv, vt = svd_tall(jac / scale[None])
    keep = sv > RCOND * sv[0]
    inv2 = jnp.where(keep, 1.0 / jnp.where(keep, sv, 1.0) ** 2, 0.0)
    pinv = ((vt.T * inv2[None]) @ vt) / scale[:, None] / scale[None, :]  # (JᵀJ)⁺
    dof = jnp.maximum(n - jnp.sum(~fixed), 1)
    if hac:
        lags = bandwidth(r, n)
        meat = _long_run(jac * r[:, None], lags)
        cov = (n / dof) * pinv @ meat @ pinv
    else:
        lags = jnp.asarray(0.0, r.dtype)
        cov = jnp.sum(r * r) / dof * pinv
    # a dropped direction with a component on a free parameter: that parameter's variance is inf
    loose = jnp.any((~keep)[:, None] & (jnp.abs(vt) > 1e-6), axis=0) & ~fixed
    cov = jnp.where(loose[:, None] | loose[None, :], jnp.inf, cov)
    cov = jnp.where(fixed[:, None] | fixed[None, :], jnp.nan, cov)
    return cov, lags


@jax.jit
def colour_factor(r, weight=None):
    """``(κ, L)``: the residuals' long-run variance over their variance, ``κ = max(1, 1 + 2 Σ_{l=1..L}
    (1 − l/(L+1)) ρ_l)`` (Bartlett weights, ``ρ_l`` the lag-l autocorrelation of ``r`` (n,) in time
    order, ``L`` = :func:`bandwidth`). ``n/κ`` is the effective number of independent samples: for
    AR(1) residuals κ → (1 + ρ)/(1 − ρ). Floored at 1 so that negatively correlated residuals never
    narrow an interval. ``weight`` (n,): a padding mask (1 on the samples, 0 on trailing padding
    rows, whose ``r`` must be 0), the samples' κ whatever the padded length."""
    if weight is None:
        n, rc = r.shape[0], r - jnp.mean(r)
    else:
        n = jnp.sum(weight > 0)
        rc = jnp.where(weight > 0, r - jnp.sum(r) / n, 0.0)
    lags = bandwidth(r, n)
    ratio = _long_run(rc[:, None], lags)[0, 0] / jnp.maximum(jnp.sum(rc * rc), jnp.finfo(r.dtype).tiny)
    return jnp.maximum(ratio, 1.0), lags


def correlation(cov):
    """Correlation matrix (NumPy) of ``cov``; ``nan`` where a variance is infinite, zero or nan."""
    cov = np.asarray(cov, float)
    sd = np.sqrt(np.diag(cov))
    ok = np.isfinite(sd) & (sd > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    corr[~(ok[:, None] & ok[None, :])] = np.nan
    return corr
