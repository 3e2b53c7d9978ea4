"""Conformance of every catalogue effect, looping over the registry: the record is complete for
every reader, the extension at its neutral values is the base model exactly, its gradients are
finite, its explanation renders with its parameters, every pair of effects has a separating run,
and a clean simulated recording with the effect at its default magnitude gives the magnitude back
from the extended fit (started at the truth's Polach parameters and the neutral extra)."""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.scenarios import get_scenario
from jadhesion.data.simulator import simulate
from jadhesion.diagnose import extensions as ext
from jadhesion.diagnose import features, fitting, select
from jadhesion.diagnose.explain import effect_sentence
from jadhesion.diagnose.signals import from_columns
from jadhesion.models.effect_spec import IMPLAUSIBLE_BEYOND, Detection
from jadhesion.models.effects import EFFECT_NAMES, EFFECTS, on_clock
from jadhesion.models.kinematics import creepage
from jadhesion.models.polach import polach_adhesion
from jadhesion.status import Status

N = 1000
RAW = ("time", "vehicle_speed", "wheel_speed", "traction_torque")
#: Relative tolerance of the recovered magnitude: the extensions are the simulator's factors up to
#: a lag picked on a grid (thermal), so a few per cent is the model gap.
TOL = {"thermal_softening": 0.5}
#: Effects whose extension does not give the simulator's magnitude back on this recording (measured
#: on it, σ = 0.015 from the torque noise; Δχ² = ΔSSE/σ² of the fit with the magnitude held; strict,
#: so a fix shows). None is a start-value problem: starts across the range end at the same minimum.
NOT_RECOVERED = {
    "signal_delay": "errors in variables: the re-alignment τ·dT/dt regresses on the smoothed recorded torque "
    "rate, whose noise attenuates τ (least squares 0.059 s on noise-free signals, 0.012 s with the noise); "
    "the joint fit ends at 0.0001 s from any start in −0.1…0.2 s (Δχ² = 83 at the true 0.05 s). Separating "
    "run: a torque step timed against the wheel acceleration, which the simulator does not make",
    "torque_offset": "traded against mu0 and kS on the saturated curve: every start in −0.02…0.1 ends at "
    "0.068; Δχ² ≤ 1.5 over 0.04–0.1 and 5.7 at the true 0.02 (mu0 0.268 → 0.222, kS 0.96 → 0.69). "
    "Separating run: coasting, which reads the bias (test_torque_offset_is_recovered_on_its_exposing_run)",
    "load_transfer": "not identifiable while the tractive effort follows this axle's adhesion (mu_hat ≈ μ − "
    "m μ², a curve-shape change): with m_A held at 0 the profile over m_L has Δχ² 0.6 at 0, 1.9 at the "
    "true 0.5, 6.6 at 1 against its minimum at the bound −0.3 (the same shape without the effect). "
    "Separating run: other axles' torque changed independently, which the simulator does not make",
}


def _signals(name, magnitude, coast_s=0.0):
    scenario = get_scenario("wet").replace(coast_s=coast_s)
    sim = simulate(scenario, 7, [(name, magnitude)] if name else [], N, sensors="clean")
    return sim, from_columns({k: sim.columns[k] for k in RAW}, sim.vehicle)


@pytest.fixture(scope="module")
def clean():
    return _signals(None, 0.0)


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_neutral_extension_is_the_base_model(name, clean):
    """With the effect switched on at its record's neutral values (every other extra off, at
    values far from neutral) the extended model is the plain Polach curve and the target the
    observer's adhesion, bit for bit (op by op: under jit XLA may fuse the two programs
    differently, a last-bit difference that says nothing about the extension)."""
    _, sig = clean
    theta = jnp.array([0.43, 0.9, 0.35, 0.36, 0.13])
    extras = ext.NEUTRAL + 0.3
    for p in EFFECTS[name].extension:
        extras[ext.EXTRA_NAMES.index(p.name)] = p.neutral
    with jax.disable_jit():
        target, pred = ext.predict(jnp.concatenate([theta, extras]), ext.active_mask([name]), sig)
    slip = sig.wheel_speed - sig.speed
    base = polach_adhesion(theta, creepage(slip, sig.speed), slip, sig.k_eps)
    np.testing.assert_array_equal(np.asarray(pred), np.asarray(base))
    np.testing.assert_array_equal(np.asarray(target), np.asarray(sig.adhesion))


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_gradient_of_each_extension_is_finite(name, clean):
    _, sig = clean
    params = jnp.concatenate([jnp.array([0.43, 0.9, 0.35, 0.36, 0.13]), ext.NEUTRAL])
    args = (ext.active_mask([name]), sig.weight, sig)
    g = np.asarray(jax.grad(lambda p: jnp.sum(ext.residual(p, args) ** 2))(params))
    assert np.all(np.isfinite(g))
    assert g[5 + ext.EXTRA_NAMES.index(EFFECTS[name].magnitude_param)] != 0.0


def test_a_limit_holds_where_blind_tests_named_nine_in_ten_above_it():
    """:meth:`Detection.limit_holds`: ≥ 90 % of the blind cases above the limit named; None
    without any case above it."""
    held = [Detection(None, None, "", own_limit=c).limit_holds() for c in ((9, 10), (8, 10), (0, 0), (1, 1))]
    assert held == [True, False, None, True]


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_registry_record_is_complete(name, clean):
    """Every record is usable by every reader: the extension tables hold its parameters, its
    magnitude parameter is 0 at no effect and its box holds the typical range (as does the
    simulator's interval), the revealing signal is one the residual analysis computes, and the
    documented detection thresholds lie inside the typical range they were measured over."""
    _, sig = clean
    spec = EFFECTS[name]
    assert name in ext.NAMES and spec.magnitude_param == spec.extension[0].name
    for p in spec.extension:
        i = 5 + ext.EXTRA_NAMES.index(p.name)
        assert ext.BOUNDS[0][i] == p.lower <= p.neutral == ext.NEUTRAL[i - 5] <= p.upper == ext.BOUNDS[1][i]
        assert p.unit
    mag = spec.extension[0]
    lo, hi = spec.typical
    assert 0.0 < lo < hi and mag.neutral == 0.0
    assert mag.lower <= (-hi if spec.signed else 0.0) and hi <= mag.upper
    assert spec.low <= (-hi if spec.signed else 0.0) and hi <= spec.high
    assert spec.signal in features.library(sig, sig.adhesion)
    assert len(spec.exposing_run) > 20 and len(spec.factor) > 20
    for threshold in (spec.detection.top1, spec.detection.in_set):
        assert threshold is None or lo <= threshold <= hi, (name, threshold)
    named, above = spec.detection.own_limit  # counts of blind cases: named of those above the limit
    assert all(isinstance(k, int) for k in (named, above)) and 0 <= named <= above
    # a fitted size is plausible across the typical range and a margin, not far beyond it
    assert all(spec.plausible(s * m) for s in (1, -1) for m in (lo, hi, IMPLAUSIBLE_BEYOND * hi))
    assert not spec.plausible(1.01 * IMPLAUSIBLE_BEYOND * hi) and not spec.plausible(
        -2 * IMPLAUSIBLE_BEYOND * hi
    )
    # the same limits read by the diagnosis, over every parameter: the neutral fit is plausible, a
    # magnitude past the margin is named, and a parameter with a physical limit is implausible at
    # its box's edge (where a fit bending the curve with it ends)
    neutral = {p.name: p.neutral for p in spec.extension}
    assert spec.implausible(neutral) == {}
    assert list(spec.implausible({**neutral, mag.name: 1.01 * IMPLAUSIBLE_BEYOND * hi})) == [mag.name]
    for p in spec.extension[1:]:
        if p.plausible_abs is not None:
            assert 0.0 < p.plausible_abs < max(abs(p.lower), abs(p.upper))
            edge = p.lower if abs(p.lower) > p.plausible_abs else p.upper
            assert list(spec.implausible({**neutral, p.name: edge})) == [p.name]


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_explanation_renders_with_its_parameters(name, clean):
    """The sentence renders from the fitted extension parameters (and the diagnosis' derived
    change time and thermal lag) and the vehicle, and it says the magnitude: two magnitudes give
    two sentences."""
    sim, _ = clean
    spec = EFFECTS[name]
    texts = set()
    for magnitude in (0.05, 0.2):
        params = {p.name: p.neutral + 0.02 for p in spec.extension}
        params.update({spec.magnitude_param: magnitude, "t_change_s": 10.0, "tau_th_s": 2.0})
        text = effect_sentence(name, params, sim.vehicle)
        assert len(text) > 40 and "{" not in text
        texts.add(text)
    assert len(texts) == 2


def test_every_pair_has_one_separating_run():
    """Each of the 21 pairs is written once, in the record of the effect that comes first, and the
    diagnosis' lookup finds it in either order."""
    for i, name in enumerate(EFFECT_NAMES):
        assert set(EFFECTS[name].separating) <= set(EFFECT_NAMES[i + 1 :]), name
    pairs = list(itertools.combinations(EFFECT_NAMES, 2))
    assert sum(len(s.separating) for s in EFFECTS.values()) == len(pairs) == 21
    for a, b in pairs:
        run = select.experiment(a, b)
        assert len(run) > 20 and run == select.experiment(b, a)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=NOT_RECOVERED[n]))
        if n in NOT_RECOVERED
        else n
        for n in EFFECT_NAMES
    ],
)
def test_extended_fit_recovers_the_magnitude(name):
    _recovers(name, EFFECTS[name].default, coast_s=0.0)


def test_torque_offset_is_recovered_on_its_exposing_run():
    """The torque offset that the plain run trades against mu0 and kS (:data:`NOT_RECOVERED`) comes
    back on its registry's exposing run, the same recording with a 3 s coasting gap (``simulate
    --coast 3``): zero torque there reads the bias. Measured 0.0200 (0.068 without the gap)."""
    assert "coasting" in EFFECTS["torque_offset"].exposing_run
    _recovers("torque_offset", EFFECTS["torque_offset"].default, coast_s=3.0)


def _recovers(name, magnitude, coast_s):
    """The extended fit from the truth's Polach parameters and the neutral extra converges and
    gives ``magnitude`` back within :data:`TOL` (10 % by default)."""
    sim, sig = _signals(name, magnitude, coast_s)
    p0 = np.concatenate([list(sim.truth["params"].values()), ext.NEUTRAL])
    if name == "rail_change":  # the simulator's change time, as the diagnosis' grid start finds it
        p0[5 + ext.EXTRA_NAMES.index("u_change")] = 0.5
    rows = (p0[None], np.array([fitting.free_indices((name,))]), np.asarray(ext.active_mask([name]))[None])
    table = fitting.fit_candidates(*rows, fitting.pad_signals(sig), N, folds=False)
    assert int(table.status[0]) == Status.CONVERGED
    est = float(table.params[0, 5 + ext.EXTRA_NAMES.index(EFFECTS[name].magnitude_param)])
    assert abs(est - magnitude) <= TOL.get(name, 0.1) * abs(magnitude), (est, magnitude)


def _base_and_effect_with_folds(name, p0, sig):
    """Fit table (with CV folds) of the plain model and of ``name``'s extension, both from ``p0``."""
    rows = (
        np.stack([p0, p0]),
        np.array([fitting.free_indices(()), fitting.free_indices((name,))]),
        np.stack([np.zeros(ext.N_EXTRA, bool), np.asarray(ext.active_mask([name]))]),
    )
    return fitting.fit_candidates(*rows, fitting.pad_signals(sig), N, folds=True)


@pytest.mark.parametrize("name", [n for n in EFFECT_NAMES if any(p.fold_fixed for p in EFFECTS[n].extension)])
def test_folds_converge_when_one_holds_out_the_effects_place(name):
    """A parameter that places an effect in time is kept at the full-data fit in the CV folds, so
    the fold whose held-out block contains the place (the simulator's change sits in block 2 of 5)
    converges instead of stalling on the flat direction, and the held-out error beats the base
    model's. Dry rail with realistic sensors: with the place free in the folds, that fold stalls
    (measured at 3b2967b)."""
    sim = simulate("dry", 3, [(name, EFFECTS[name].default)], N, sensors="realistic")
    sig = from_columns({k: sim.columns[k] for k in RAW}, sim.vehicle)
    p0 = np.concatenate([list(sim.truth["params"].values()), ext.NEUTRAL])
    for p in EFFECTS[name].extension[1:]:  # the place starts off the truth (0.5), inside block 2
        p0[5 + ext.EXTRA_NAMES.index(p.name)] = 0.45 if p.fold_fixed else p.neutral
    table = _base_and_effect_with_folds(name, p0, sig)
    assert [int(s) for s in table.status] == [Status.CONVERGED] * 2
    assert [int(s) for s in table.fold_status] == [Status.CONVERGED] * 2
    assert float(table.heldout_mae[1]) < 0.9 * float(table.heldout_mae[0])  # measured 0.76


def test_a_fold_that_sees_one_side_of_a_change_keeps_its_size():
    """A rail change at 90 % of the run (the simulator's at 20 s of a 2–22 s window, clean sensors):
    the fold holding out the last block trains only before the change, so it keeps the change's
    size at the full fit, not only its time. Held-out error 0.0106 against the base's 0.0203; with
    the size free in that fold it ran off along the flat direction and the held-out error was
    0.048, worse than the base model's (measured before the change)."""
    name = "rail_change"
    sim = simulate("dry", 3, [(name, EFFECTS[name].default)], 2 * N, sensors="clean")
    keep = slice(N // 10, 11 * N // 10)
    sig = from_columns({k: np.asarray(sim.columns[k])[keep] for k in RAW}, sim.vehicle)
    p0 = np.concatenate([list(sim.truth["params"].values()), ext.NEUTRAL])
    p0[ext.U_CHANGE] = 0.88
    table = _base_and_effect_with_folds(name, p0, sig)
    assert [int(s) for s in table.fold_status] == [Status.CONVERGED] * 2
    assert 0.85 < float(table.params[1, ext.U_CHANGE]) < 0.95
    assert float(table.heldout_mae[1]) < 0.7 * float(table.heldout_mae[0])


def test_a_rail_change_is_explained_on_the_recordings_clock():
    """A change on a clock that starts at 0 reads in seconds; on a logger's epoch clock (its first
    sample 1.7·10⁹ s) as seconds after the first fitted sample, the clock's own reading beside."""
    params = {"drop": 0.2, "t_change_s": 1_700_000_018.04}
    text = EFFECTS["rail_change"].explain({**params, "t_start_s": 1_700_000_000.0})
    assert "t ≈ 18.0 s after the first fitted sample (1700000018.0 s on the recording's clock)" in text
    assert "t ≈ 18.0 s:" in EFFECTS["rail_change"].explain({**params, "t_change_s": 18.04})
    assert on_clock((17.25, 18.75), 12.0) == "17.2–18.8 s"
