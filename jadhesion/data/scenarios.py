"""The three 22E traction tests of paper 001 (§4, DESIGN §1 table) and their envelope statistics.

The published numbers (true Polach parameters, mean speed, maximum slip velocity and creep, observed
``mu_hat`` range and mean, the paper's model error) are fixed. The test's creep profile and sensor
noise are not published; the calibration fields below are chosen so that simulated recordings match
the published envelope within ±15 % and the error of the true parameters against ``mu_hat`` matches
the paper's error within ±10 % (``tests/test_simulator.py``).

The ``mu_hat`` *range* is taken as the 0.5 %–99.5 % quantiles of the observed samples: the sand
test's published range [0.12, 0.34] cannot hold the true curve at its own maximum creep (≈ 0.39),
so the paper's range must ignore a few extreme samples. Raw min/max are reported beside it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import InputError
from ..models.polach import PARAM_NAMES, polach_adhesion
from .dataset import to_dataset

KMH = 1.0 / 3.6  # m/s per km/h


@dataclasses.dataclass(frozen=True)
class Scenario:
    """One traction test: published envelope plus the (unpublished, chosen) test profile and noise.

    Published: ``params`` (kA, kS, mu0, A, B), ``mean_speed_kmh``, ``max_slip_kmh``, ``max_creep``,
    ``mu_low``/``mu_high``/``mu_mean`` [-], ``paper_error`` (MAE of the identified model).

    Chosen (calibrated): the creep reference ``s_ref(t)`` starts at ``creep_start``, reaches
    ``creep_base`` after ``ramp_fraction`` of the recording and wanders log-normally around it with
    standard deviation ``wander`` [-]; one slip excursion peaks at ``max_creep`` (cos² pulse of
    half-width ``excursion_width_s`` [s]) when the speed ramp passes ``max_slip / max_creep``, and
    ``minor_excursions`` more reach ``minor_peak`` × ``max_creep``. The load holds the speed on a
    ramp ``v_mean (1 + speed_ramp (t/T − 1/2))``. ``torque_noise`` [N·m]: the torque channel's white
    noise (the speed channels' noise is the sensor model's, :mod:`.sensors`). ``coast_s`` [s]: a
    coasting gap of that length, the creep reference taken to 0 (none of the published tests has
    one; default 0): the run that reads a torque offset and the speed sensors' own error
    (:func:`.traction_profile.coast_window`).
    """

    name: str
    params: tuple
    mean_speed_kmh: float
    max_slip_kmh: float
    max_creep: float
    mu_low: float
    mu_high: float
    mu_mean: float
    paper_error: float
    creep_base: float
    creep_start: float
    ramp_fraction: float
    wander: float
    excursion_width_s: float
    minor_excursions: int
    minor_peak: float
    speed_ramp: float
    torque_noise: float
    coast_s: float = 0.0

    @property
    def mean_speed(self) -> float:
        """Mean speed [m/s]."""
        return self.mean_speed_kmh * KMH

    @property
    def max_slip(self) -> float:
        """Maximum slip velocity [m/s]."""
        return self.max_slip_kmh * KMH

    def replace(self, **changes) -> "Scenario":
        """A copy with fields changed."""
        return dataclasses.replace(self, **changes)


#: Profile settings shared by all three tests: ramp-in over the first 4 % of the recording, speed
#: ramp ±20 % about the mean.
_SHARED = dict(ramp_fraction=0.04, speed_ramp=0.4)
#: The dry and wet tests' wander and excursions: a slow main excursion and two minor ones.
_DRY_WET = dict(wander=0.25, excursion_width_s=0.6, minor_excursions=2, minor_peak=0.3)

SCENARIOS = {
    s.name: s
    for s in (
        Scenario(
            "dry",
            (0.4288, 1.0, 0.3555, 0.3575, 0.1316),
            2.2,
            1.65,
            0.8,
            0.23,
            0.42,
            0.36,
            0.0108,
            creep_base=0.0052,
            creep_start=0.0022,
            torque_noise=1700.0,
            **_SHARED,
            **_DRY_WET,
        ),
        Scenario(
            "wet",
            (1.0, 1.0, 0.2610, 0.6858, 0.2251),
            5.5,
            2.1,
            0.4,
            0.16,
            0.28,
            0.22,
            0.0119,
            creep_base=0.0024,
            creep_start=0.0012,
            torque_noise=1850.0,
            **_SHARED,
            **_DRY_WET,
        ),
        Scenario(
            "sand",
            (1.0, 0.4089, 0.4205, 0.0, 0.1554),
            5.3,
            1.6,
            0.32,
            0.12,
            0.34,
            0.29,
            0.0167,
            creep_base=0.0062,
            creep_start=0.0008,
            torque_noise=2600.0,
            wander=0.15,
            excursion_width_s=0.12,
            minor_excursions=0,
            minor_peak=0.1,
            **_SHARED,
        ),
    )
}


def get_scenario(scenario) -> Scenario:
    """A :class:`Scenario` from itself or its name; unknown names raise :class:`InputError`."""
    if isinstance(scenario, Scenario):
        return scenario
    if scenario not in SCENARIOS:
        raise InputError(f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    return SCENARIOS[scenario]


#: Quantiles that define the observed-adhesion "range" [-].
RANGE_QUANTILES = (0.005, 0.995)


def envelope(result) -> dict:
    """Envelope statistics of a simulated recording, in the paper's units (km/h for speeds).

    Returns ``mean_speed_kmh``, ``max_slip_kmh``, ``max_creep`` (magnitudes: braking tests
    have negative slip), ``mu_low``/``mu_high`` (the
    :data:`RANGE_QUANTILES` of ``mu_hat``), ``mu_min``/``mu_max`` (raw), ``mu_mean``, and
    ``true_param_mae``: mean |Polach(true params; recorded s, w) − mu_hat|, the error a perfect
    identification would reach on this recording.
    """

    cols = result.columns
    mu_hat = np.asarray(cols["adhesion"])
    theta = np.array([result.truth["params"][k] for k in PARAM_NAMES])
    model = np.asarray(polach_adhesion(theta, cols["creepage"], cols["slip_velocity"], result.truth["k_eps"]))
    data = to_dataset(result)
    smoothed = np.asarray(polach_adhesion(theta, data.creep, data.slip, result.truth["k_eps"]))
    low, high = np.quantile(mu_hat, RANGE_QUANTILES)
    return {
        "mean_speed_kmh": float(np.mean(cols["vehicle_speed"]) / KMH),
        "max_slip_kmh": float(np.max(np.abs(cols["slip_velocity"])) / KMH),
        "max_creep": float(np.max(np.abs(cols["creepage"]))),
        "mu_low": float(low),
        "mu_high": float(high),
        "mu_min": float(mu_hat.min()),
        "mu_max": float(mu_hat.max()),
        "mu_mean": float(np.mean(mu_hat)),
        "true_param_mae": float(np.mean(np.abs(smoothed - mu_hat))),
        "true_param_mae_raw": float(np.mean(np.abs(model - mu_hat))),
    }


def paper_envelope(scenario) -> dict:
    """The published counterparts of :func:`envelope`'s keys."""
    s = get_scenario(scenario)
    return {
        "mean_speed_kmh": s.mean_speed_kmh,
        "max_slip_kmh": s.max_slip_kmh,
        "max_creep": s.max_creep,
        "mu_low": s.mu_low,
        "mu_high": s.mu_high,
        "mu_mean": s.mu_mean,
        "true_param_mae": s.paper_error,
    }
