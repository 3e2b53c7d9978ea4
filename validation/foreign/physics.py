"""Physics of the foreign generator: vehicles, Hertz contact, Kalker c11, Polach's law.

Written from DESIGN §1 and the Polach paper, independently of ``jadhesion`` (no import, no shared
code). Units: SI throughout (m, N, kg, Pa, s); creepage dimensionless, slip velocity in m/s.

**Contact.** Hertz (Johnson, *Contact Mechanics* §4.2) with relative curvatures ``1/(2 R_wheel)``
along the rolling direction and ``(1/R_rail + 1/R_profile)/2`` across; the eccentricity solves the
curvature-ratio equation by ``scipy.optimize.brentq`` with ``scipy.special.ellipk/ellipe``.
**c11** comes from a *coarse* excerpt of Kalker's Table E.3 (:data:`C11_TABLE`, steps of 0.2 in
a/b or b/a, ν = 0, 0.25, 0.5) interpolated linearly in ``ln(a/b)`` and in ν. jadhesion interpolates
the full table (steps of 0.1), so the two c11 differ by well under 1 % for the three vehicles here;
the truth file records this generator's c11 and gradient constant.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

GRAVITY = 9.81  # m/s²

#: Kalker's c11 (Table E.3), coarse excerpt: rows (ln(a/b), c11 at ν = 0, 0.25, 0.5).
C11_TABLE = np.array(
    [
        [math.log(0.2), 2.59, 3.37, 4.81],
        [math.log(0.4), 2.78, 3.53, 4.82],
        [math.log(0.6), 2.98, 3.72, 4.91],
        [math.log(0.8), 3.19, 3.91, 5.05],
        [0.0, 3.40, 4.12, 5.20],
        [-math.log(0.8), 3.65, 4.36, 5.42],
        [-math.log(0.6), 4.06, 4.78, 5.80],
        [-math.log(0.4), 4.84, 5.57, 6.57],
        [-math.log(0.2), 6.96, 7.78, 8.82],
    ]
)
_C11_NU = np.array([0.0, 0.25, 0.5])


@dataclasses.dataclass(frozen=True)
class ForeignVehicle:
    """A locomotive as this generator sees it (the sidecar carries the contract keys).

    Attributes: axle_load_kg [kg]; wheel_radius_m nominal rolling radius [m]; wheelset_inertia_kgm2
    J at the axle [kg·m²]; locomotive_mass_kg [kg]; n_axles (all powered alike);
    observer_time_constant_s T0 [s] suggested for the observer; rail_head_radius_m,
    wheel_profile_radius_m transverse radii [m]; shear_modulus_pa G [Pa]; poisson_ratio ν;
    max_torque_nm motor torque limit at the axle [N·m]; cog_height_m, coupler_height_m [m]
    (load transfer).
    """

    name: str
    axle_load_kg: float
    wheel_radius_m: float
    wheelset_inertia_kgm2: float
    locomotive_mass_kg: float
    n_axles: int
    observer_time_constant_s: float
    rail_head_radius_m: float
    wheel_profile_radius_m: float = math.inf
    shear_modulus_pa: float = 8.0e10
    poisson_ratio: float = 0.30
    max_torque_nm: float = 6.0e4
    cog_height_m: float = 1.8
    coupler_height_m: float = 1.05

    @property
    def axle_weight_n(self) -> float:
        """Static axle load as a force [N]."""
        return self.axle_load_kg * GRAVITY

    @property
    def wheel_load_n(self) -> float:
        """Static wheel load Q [N] (half the axle)."""
        return 0.5 * self.axle_weight_n

    def semi_axes(self) -> tuple:
        """Hertz semi-axes (a rolling, b lateral) [m] at the static wheel load."""
        return hertz(
            self.wheel_radius_m,
            self.rail_head_radius_m,
            self.wheel_profile_radius_m,
            self.wheel_load_n,
            self.shear_modulus_pa,
            self.poisson_ratio,
        )

    def c11(self) -> float:
        """Kalker's c11 [-] of the static contact."""
        a, b = self.semi_axes()
        return kalker_c11(a / b, self.poisson_ratio)

    def k_eps(self) -> float:
        """Polach gradient constant ``(2/3) C π a² b / Q`` [-], ``C = 3 G c11 / (8 a)``."""
        a, b = self.semi_axes()
        stiffness = 3.0 * self.shear_modulus_pa * self.c11() / (8.0 * a)
        return 2.0 / 3.0 * stiffness * math.pi * a * a * b / self.wheel_load_n

    def sidecar(self) -> dict:
        """The recording sidecar (DESIGN §3 keys) that lets a reader rebuild this contact."""
        a, b = self.semi_axes()
        return {
            "name": self.name,
            "axle_load_kg": self.axle_load_kg,
            "wheel_radius_m": self.wheel_radius_m,
            "wheelset_inertia_kgm2": self.wheelset_inertia_kgm2,
            "locomotive_mass_kg": self.locomotive_mass_kg,
            "observer_time_constant_s": self.observer_time_constant_s,
            "rail_head_radius_m": self.rail_head_radius_m,
            "wheel_load_n": self.wheel_load_n,
            "contact_semi_axes_m": [a, b],
            "shear_modulus_pa": self.shear_modulus_pa,
            "poisson_ratio": self.poisson_ratio,
        }


#: The vehicles (J, T0, heights and radii are typical values chosen here, not published data).
VEHICLES = {
    "coco_22e": ForeignVehicle(
        "coco_22e", 21500.0, 0.61, 3000.0, 129000.0, 6, 0.05, 0.30, max_torque_nm=6.5e4
    ),
    "bobo_20t": ForeignVehicle(
        "bobo_20t",
        20000.0,
        0.625,
        2300.0,
        80000.0,
        4,
        0.04,
        0.30,
        shear_modulus_pa=8.1e10,
        poisson_ratio=0.28,
        max_torque_nm=6.0e4,
        cog_height_m=1.6,
        coupler_height_m=1.06,
    ),
    "coco_25t": ForeignVehicle(
        "coco_25t",
        25000.0,
        0.50,
        1900.0,
        150000.0,
        6,
        0.08,
        0.254,
        wheel_profile_radius_m=1.0,
        shear_modulus_pa=7.9e10,
        poisson_ratio=0.29,
        max_torque_nm=6.0e4,
        cog_height_m=1.9,
        coupler_height_m=0.87,
    ),
}


def hertz(wheel_radius, rail_radius, profile_radius, load, shear_modulus, nu) -> tuple:
    """Hertz semi-axes ``(a, b)`` [m], a along the rolling direction; same steel both bodies."""
    along = 0.5 / wheel_radius
    across = 0.5 * (1.0 / rail_radius + 1.0 / profile_radius)
    small, big = min(along, across), max(along, across)
    e_star = 2.0 * shear_modulus * (1.0 + nu) / (2.0 * (1.0 - nu * nu))

    def excess(m):  # curvature ratio of an ellipse with eccentricity² m, minus the target
        k, e = ellipk(m), ellipe(m)
        return (e / (1.0 - m) - k) / (k - e) - big / small

    m = 0.0 if big == small else brentq(excess, 1e-12, 1.0 - 1e-14, xtol=1e-15)
    m_safe = max(m, 1e-9)
    k, e = ellipk(m_safe), ellipe(m_safe)
    long = (3.0 * load * (k - e) / (2.0 * math.pi * e_star * m_safe * small)) ** (1.0 / 3.0)
    short = long * math.sqrt(1.0 - m)
    return (long, short) if along <= across else (short, long)


def kalker_c11(a_over_b, nu) -> float:
    """c11 [-] from :data:`C11_TABLE`, linear in ln(a/b) (clamped to 0.2 ≤ a/b ≤ 5) and in ν."""
    x = math.log(a_over_b)
    per_nu = [np.interp(x, C11_TABLE[:, 0], C11_TABLE[:, j + 1]) for j in range(3)]
    return float(np.interp(nu, _C11_NU, per_nu))


def polach(creep, slip, ka, ks, mu0, a_ratio, b_slope, k_eps) -> float:
    """Polach's adhesion coefficient ``mu_adh`` [-] (scalar; odd in creep and slip together).

    ``mu(w) = mu0 ((1−A) e^{−B|w|} + A)``, ``eps = k_eps |s| / mu``,
    ``mu_adh = (2 mu/π)(kA eps/(1 + (kA eps)²) + atan(kS eps))``; B in s/m, w in m/s.
    """
    mu = mu0 * ((1.0 - a_ratio) * math.exp(-b_slope * abs(slip)) + a_ratio)
    if mu <= 1e-9:
        return 0.0
    eps = k_eps * abs(creep) / mu
    value = 2.0 * mu / math.pi * (ka * eps / (1.0 + (ka * eps) ** 2) + math.atan(ks * eps))
    return math.copysign(value, creep)


#: Rail conditions: Polach (kA, kS, mu0, A, B) centres to randomise around (paper 001 Table 1's
#: three 22E fits and Polach 2005's dry/wet sets).
CONDITIONS = {
    "dry_22e": (0.4288, 1.0, 0.3555, 0.3575, 0.1316),
    "wet_22e": (1.0, 1.0, 0.2610, 0.6858, 0.2251),
    "sand_22e": (1.0, 0.4089, 0.4205, 0.0, 0.1554),
    "dry_polach": (1.0, 0.4, 0.45, 0.4, 0.6),
    "wet_polach": (0.3, 0.75, 0.30, 0.4, 0.2),
}
PARAM_NAMES = ("kA", "kS", "mu0", "A", "B")


def random_params(rng: np.random.Generator) -> dict:
    """Polach parameters in [0, 1]⁵: a random condition, each value scaled by ~N(1, 0.15)."""
    centre = CONDITIONS[rng.choice(sorted(CONDITIONS))]
    values = [float(np.clip(c * rng.normal(1.0, 0.15), 0.02, 1.0)) for c in centre]
    values[3] = float(np.clip(centre[3] + rng.normal(0.0, 0.05), 0.0, 0.9))  # A may be 0
    values[2] = float(np.clip(values[2], 0.2, 0.55))
    return dict(zip(PARAM_NAMES, values, strict=True))
