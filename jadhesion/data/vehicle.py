"""Vehicle specification: the South African 22E locomotive (paper 001, Table 1) and its contact.

Published (Table 1): Co-Co, 129 t, axle load 21.5 t, wheel diameter 1220 mm new (1180 semi-worn,
1140 worn), gear ratio 6.0588, 480 kN starting tractive effort, 1065 mm gauge.

Not published, chosen here (documented defaults, all overridable through a recording's sidecar):

* ``wheelset_inertia_kgm2 = 3000``: a 1220 mm wheelset (~1100 kg·m²) plus the traction motor's
  rotor (~50 kg·m²) and pinion/gear reflected through the gear ratio squared (6.0588² ≈ 36.7), giving
  ~2900–3000 kg·m² at the axle.
* ``rail_head_radius_m = 0.3``: crown radius of the 48/57 kg/m rail heads used on Cape gauge.
* wheel profile transverse radius ∞ (conical tread, new profile).
* ``observer_time_constant_s = 0.05``: T0 of the adhesion observer's derivative filter.
* steel: E = 2.1e11 Pa, ν = 0.28, G = E / (2 (1 + ν)) ≈ 8.2e10 Pa.
* geometry of load transfer (the ``load_transfer`` effect, :func:`..models.effects.load_factor`):
  ``coupler_height_m = 0.9`` (drawbar pull above rail; knuckle couplers sit at 0.85–0.9 m),
  ``cog_height_m = 1.5`` (centre of gravity of a loaded Co-Co body above rail; 1.4–1.8 m is usual),
  ``bogie_centres_m = 11.0`` (bogie-pivot spacing of a ~20 m Co-Co). A stiff body over its bogies
  shifts ``2 h_c / L_b`` ≈ 0.16 of a leading-bogie axle's static load per unit of drawbar pull
  ``F_d/(M g)`` (:attr:`Vehicle.body_pitch_transfer`); the bogies' own pitch adds to it.

With these, Hertz gives a ≈ 8.4 mm (rolling) × b ≈ 5.2 mm, Kalker c11 ≈ 4.84 and the Polach
gradient constant k_eps ≈ 130 (``eps = k_eps · s / mu``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Optional

import jax
import jax.numpy as jnp

from ..errors import VehicleError
from ..models.contact import Contact, hertz_semi_axes
from ..models.polach import gradient_constant

GRAVITY = 9.81  # m/s²


@dataclasses.dataclass(frozen=True)
class Vehicle:
    """A locomotive and its wheel–rail contact. Field names match the recording sidecar keys."""

    name: str = "22E"
    axle_load_kg: float = 21500.0
    wheel_radius_m: float = 0.61
    wheelset_inertia_kgm2: float = 3000.0
    locomotive_mass_kg: float = 129000.0
    observer_time_constant_s: float = 0.05
    rail_head_radius_m: float = 0.3
    wheel_load_n: Optional[float] = None
    contact_semi_axes_m: Optional[tuple] = None
    shear_modulus_pa: Optional[float] = None
    poisson_ratio: float = 0.28
    young_modulus_pa: float = 2.1e11
    wheel_profile_radius_m: float = float("inf")
    gear_ratio: float = 6.0588
    n_axles: int = 6
    starting_tractive_effort_n: float = 480e3
    coupler_height_m: float = 0.9
    cog_height_m: float = 1.5
    bogie_centres_m: float = 11.0

    @property
    def axle_weight_n(self) -> float:
        """Axle load as a force [N]."""
        return self.axle_load_kg * GRAVITY

    @property
    def wheel_load(self) -> float:
        """Normal force on one wheel Q [N] (half the axle weight unless overridden)."""
        return self.wheel_load_n if self.wheel_load_n is not None else 0.5 * self.axle_weight_n

    @property
    def shear_modulus(self) -> float:
        """G [Pa]."""
        if self.shear_modulus_pa is not None:
            return self.shear_modulus_pa
        return self.young_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def body_pitch_transfer(self) -> float:
        """Leading-axle load shifted per unit drawbar pull by a stiff body's pitch [-]: the moment
        ``F_d h_c`` over the bogie centres ``L_b``, shared by the leading bogie's ``n/2`` axles of
        static load ``M g/n`` each: ``2 h_c / L_b`` (``load_transfer``'s magnitude before bogie pitch)."""
        return 2.0 * self.coupler_height_m / self.bogie_centres_m

    def contact(self) -> Contact:
        """Contact semi-axes [m]: the sidecar override, else Hertz."""
        if self.contact_semi_axes_m is not None:
            a, b = self.contact_semi_axes_m
            return Contact(jnp.asarray(float(a)), jnp.asarray(float(b)))
        return hertz_semi_axes(
            self.wheel_radius_m,
            self.rail_head_radius_m,
            self.wheel_load,
            self.young_modulus_pa,
            self.poisson_ratio,
            self.wheel_profile_radius_m,
        )

    def k_eps(self) -> float:
        """Polach gradient constant ``k_eps`` [-] (``eps = k_eps · s / mu``); computed once per
        vehicle (op by op, the contact's table lookups took ~80 ms a call); uncached when a field
        is not hashable (a list or an array given by hand). :class:`VehicleError` when it is not a
        positive finite number (a sidecar's contact numbers far outside any wheel's: a fit on it
        would be NaN or a flat curve)."""
        try:
            hash(self)
        except TypeError:
            value = _k_eps.__wrapped__(self)
        else:
            value = _k_eps(self)
        if not (math.isfinite(value) and value > 0):
            a, b = (float(x) for x in self.contact())
            raise VehicleError(
                f"vehicle {self.name!r}: its contact (wheel load {self.wheel_load:.3g} N, semi-axes "
                f"{a:.3g} x {b:.3g} m, G {self.shear_modulus:.3g} Pa) gives Polach's gradient constant "
                f"k_eps = {value:g}, not a positive finite number: check the sidecar's axle_load_kg, "
                "wheel_load_n, wheel_radius_m, rail_head_radius_m, contact_semi_axes_m, shear_modulus_pa"
            )
        return value

    def replace(self, **changes) -> "Vehicle":
        """A copy with fields changed."""
        return dataclasses.replace(self, **changes)


#: Sidecar keys accepted in a recording's JSON (DESIGN §3), with their expected types.
SIDECAR_KEYS = {
    "axle_load_kg": float,
    "wheel_radius_m": float,
    "wheelset_inertia_kgm2": float,
    "locomotive_mass_kg": float,
    "observer_time_constant_s": float,
    "rail_head_radius_m": float,
    "name": str,
    "wheel_load_n": float,
    "contact_semi_axes_m": list,
    "shear_modulus_pa": float,
    "poisson_ratio": float,
}

LOCO_22E = Vehicle()


@functools.lru_cache(maxsize=64)
def _k_eps(vehicle: Vehicle) -> float:
    """:meth:`Vehicle.k_eps` of a (frozen, hashable) vehicle, as one compiled program (its
    constants folded in) rather than op by op."""

    def k_eps():
        v = vehicle
        return gradient_constant(v.contact(), v.wheel_load, v.shear_modulus, v.poisson_ratio)

    return float(jax.jit(k_eps)())
