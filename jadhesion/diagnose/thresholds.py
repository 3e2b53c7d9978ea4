"""Documented detection thresholds: the concealed magnitude above which ``jadhesion diagnose``
names each effect correctly (top-1) in at least :data:`TARGET_ACCURACY` of blind simulated cases.

How it was measured: ``python -m benchmarks.diagnose_blind`` (saved in
``benchmarks/results/diagnose_blind.json``) simulates single-effect recordings with log-uniform
magnitudes over :attr:`jadhesion.models.effects.EffectSpec.typical`, random scenario, seed, vehicle
and (30 % of them) driving profile, and diagnoses each blind. For every effect the cases are sorted
by |magnitude|; the threshold is the smallest magnitude m such that the cases with |magnitude| ≥ m
(at least :data:`MIN_CASES` of them) have top-1 accuracy ≥ :data:`TARGET_ACCURACY`. With roughly
twenty cases per effect a threshold is uncertain by about one magnitude bin; the benchmark reports
the accuracy above the documented threshold on each new run.

``magnitude`` is ``None`` where the effect never reaches the target inside the simulated range: the
diagnoser can still report it inside an indistinguishable set (``in_set``, the magnitude above
which the truth is the verdict *or* in its reported set ≥ 90 % of the time, where one exists).
Units are those of the simulator's catalogue (:mod:`jadhesion.models.effects`).

These thresholds were measured before the per-recording null (:mod:`.null`) joined the decision
and before the simulator's default sensors became ``"realistic"``; the blind benchmark's
``top1_above_documented`` says how they hold now (``benchmarks/results/diagnose_blind.json``).
"""

from __future__ import annotations

TARGET_ACCURACY = 0.9
MIN_CASES = 5

#: Per effect: ``magnitude`` (|m| threshold for ≥ 90 % top-1, or None), ``in_set`` (threshold for the truth
#: in the reported set), ``unit``, ``note``. Measured by ``python benchmarks/diagnose_blind.py --n 220
#: --null 100 --seed 2026`` (320 recordings; 170 with one effect, 16–30 per effect; thresholds rounded up
#: to two significant figures). A threshold equal to the bottom of the registry's
#: :attr:`~jadhesion.models.effects.EffectSpec.typical` range means "from the smallest magnitude
#: simulated"; below it nothing was measured. Confirmed on a run they were not fitted to, ``--n 250 --null
#: 50 --seed 11`` (``benchmarks/results/diagnose_blind_seed11.json``): top-1 above the thresholds 21/21
#: (rail change), 21/21 (radius), 25/25 (speed), 14/15 (thermal), 81/82 in all; false alarms 0/92 clean
#: recordings (95 % CI 0–3.9 %).
DETECTION_THRESHOLDS = {
    "rail_change": {
        "magnitude": 0.023,
        "in_set": 0.023,
        "unit": "fractional μ0 drop [-]",
        "note": "24/25 named above; 25/27 over 0.022–0.48",
    },
    "wheel_radius_error": {
        "magnitude": 0.0058,
        "in_set": 0.0021,
        "unit": "relative radius error |δ| [-]",
        "note": "19/21 named above (misses: torque_offset); in set 29/30 overall",
    },
    "signal_delay": {
        "magnitude": None,
        "in_set": None,
        "unit": "torque delay τ [s]",
        "note": "not reached in 0.01–0.3 s: 4/30 named, 23 verdict none",
    },
    "speed_dependence": {
        "magnitude": 0.13,
        "in_set": 0.13,
        "unit": "relative μ0 slope per relative speed |m_V| [-]",
        "note": "7/7 named above; 2/9 below",
    },
    "torque_offset": {
        "magnitude": None,
        "in_set": None,
        "unit": "torque bias / (m g r), |β| [-] (adhesion units)",
        "note": "not reached in 0.002–0.05: 5/25 named (all ≥ 0.024), 7/25 in set",
    },
    "thermal_softening": {
        "magnitude": 0.34,
        "in_set": 0.34,
        "unit": "softening m_T per 10 kW of lagged frictional power [-]",
        "note": "9/9 named above; 3/13 below",
    },
    "load_transfer": {
        "magnitude": None,
        "in_set": None,
        "unit": "load-transfer coefficient m_L [-]",
        "note": "not reached in 0.1–1.5: 1/20 named, 19 verdict none",
    },
}
