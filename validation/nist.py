"""The 27 NIST StRD nonlinear regression problems: models in JAX and a parser of the ``.dat`` files.

Each model is ``f(x, b) -> y`` with ``b`` the 1-D parameter vector (``b[0]`` is NIST's ``b1``).
Nelson's response is ``log y`` and its predictor has two columns ``(x1, x2)``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

#: The vendored StRD files (public domain, NIST/ITL), one ``.dat`` per problem.
DATA_DIR = Path(__file__).resolve().parent / "data" / "nist_strd"

_PI = jnp.pi


def _rational(num, den):
    def f(x, b):
        top = sum(b[i] * x**i for i in range(num))
        bottom = 1.0 + sum(b[num + i] * x ** (i + 1) for i in range(den))
        return top / bottom

    return f


def _gauss(x, b):
    return (
        b[0] * jnp.exp(-b[1] * x)
        + b[2] * jnp.exp(-((x - b[3]) ** 2) / b[4] ** 2)
        + b[5] * jnp.exp(-((x - b[6]) ** 2) / b[7] ** 2)
    )


def _lanczos(x, b):
    return b[0] * jnp.exp(-b[1] * x) + b[2] * jnp.exp(-b[3] * x) + b[4] * jnp.exp(-b[5] * x)


def _misra1a(x, b):
    return b[0] * (1.0 - jnp.exp(-b[1] * x))


def _enso(x, b):
    w = 2.0 * _PI * x
    return (
        b[0]
        + b[1] * jnp.cos(w / 12)
        + b[2] * jnp.sin(w / 12)
        + b[4] * jnp.cos(w / b[3])
        + b[5] * jnp.sin(w / b[3])
        + b[7] * jnp.cos(w / b[6])
        + b[8] * jnp.sin(w / b[6])
    )


MODELS = {
    "Bennett5": lambda x, b: b[0] * (b[1] + x) ** (-1.0 / b[2]),
    "BoxBOD": _misra1a,
    "Chwirut1": lambda x, b: jnp.exp(-b[0] * x) / (b[1] + b[2] * x),
    "Chwirut2": lambda x, b: jnp.exp(-b[0] * x) / (b[1] + b[2] * x),
    "DanWood": lambda x, b: b[0] * x ** b[1],
    "ENSO": _enso,
    "Eckerle4": lambda x, b: (b[0] / b[1]) * jnp.exp(-0.5 * ((x - b[2]) / b[1]) ** 2),
    "Gauss1": _gauss,
    "Gauss2": _gauss,
    "Gauss3": _gauss,
    "Hahn1": _rational(4, 3),
    "Kirby2": _rational(3, 2),
    "Lanczos1": _lanczos,
    "Lanczos2": _lanczos,
    "Lanczos3": _lanczos,
    "MGH09": lambda x, b: b[0] * (x**2 + x * b[1]) / (x**2 + x * b[2] + b[3]),
    "MGH10": lambda x, b: b[0] * jnp.exp(b[1] / (x + b[2])),
    "MGH17": lambda x, b: b[0] + b[1] * jnp.exp(-x * b[3]) + b[2] * jnp.exp(-x * b[4]),
    "Misra1a": _misra1a,
    "Misra1b": lambda x, b: b[0] * (1.0 - (1.0 + b[1] * x / 2) ** (-2)),
    "Misra1c": lambda x, b: b[0] * (1.0 - (1.0 + 2 * b[1] * x) ** (-0.5)),
    "Misra1d": lambda x, b: b[0] * b[1] * x / (1.0 + b[1] * x),
    "Nelson": lambda x, b: b[0] - b[1] * x[:, 0] * jnp.exp(-b[2] * x[:, 1]),
    "Rat42": lambda x, b: b[0] / (1.0 + jnp.exp(b[1] - b[2] * x)),
    "Rat43": lambda x, b: b[0] / (1.0 + jnp.exp(b[1] - b[2] * x)) ** (1.0 / b[3]),
    "Roszman1": lambda x, b: b[0] - b[1] * x - jnp.arctan(b[2] / (x - b[3])) / _PI,
    "Thurber": _rational(4, 3),
}


class Problem(NamedTuple):
    """One NIST problem: data, both starting points and the certified values (float64 NumPy)."""

    name: str
    x: np.ndarray
    y: np.ndarray
    starts: tuple
    certified: np.ndarray
    certified_sd: np.ndarray
    certified_sse: float


_PARAM = re.compile(r"^\s*b\d+\s*=\s*(\S+)\s+(\S+)\s+(\S+)\s+(\S+)")


def load_problem(path) -> Problem:
    """Parse a StRD ``.dat`` file (parameter block, residual sum of squares, data after ``Data:``)."""
    path = Path(path)
    lines = path.read_text().splitlines()
    rows = [m.groups() for m in map(_PARAM.match, lines) if m]
    values = np.array([[float(v) for v in r] for r in rows])
    sse = next(float(line.split()[-1]) for line in lines if line.startswith("Residual Sum of Squares"))
    start = max(i for i, line in enumerate(lines) if line.startswith("Data:")) + 1
    data = np.array([[float(v) for v in line.split()] for line in lines[start:] if line.strip()])
    y, x = data[:, 0], data[:, 1:]
    if path.stem == "Nelson":
        y = np.log(y)
    else:
        x = x[:, 0]
    return Problem(path.stem, x, y, (values[:, 0], values[:, 1]), values[:, 2], values[:, 3], sse)


def log_relative_error(estimate, certified):
    """LRE = −log10(|estimate − certified| / |certified|), capped at 15 (digits of agreement)."""
    rel = np.abs(np.asarray(estimate) - certified) / np.abs(certified)
    return np.minimum(15.0, -np.log10(np.maximum(rel, 1e-300)))
