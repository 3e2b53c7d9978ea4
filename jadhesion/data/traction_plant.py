"""The simulator's plant: wheelset and locomotive dynamics, the speed-regulated test load and the
slip controller, integrated in time by ROS2 (:mod:`.rosenbrock`).

**Plant** (state ``y = [ω, v, z, P_th]``; wheel angular speed [rad/s], vehicle speed [m/s], PI
integral [N·m], thermal state [W]). With true rolling radius ``r``, slip ``w = ω r − v``, creepage
``s = w / max(v, floor)`` and the Polach curve ``mu(s, w)`` (effects applied,
:mod:`..models.effects`):

    J ω̇   = T − mu N1 r                     (wheelset; N1 = leading-axle weight [N])
    M v̇   = n mu N − F_res(v) − F_load(t, v)  (all n axles see the measured axle's mu)
    τ Ṗ_th = mu N1 |w| − P_th               (only used by thermal_softening)

``F_res = M g c0 + c2 v²`` (Davis, :data:`ROLLING_RESISTANCE`, :data:`AERO_DRAG`). **Test load** (a
choice, the paper does not describe it; it keeps the speed at walking pace like the paper's tests):
a speed-regulated load (dynamometer car / load locomotive in dynamic brake) whose drawbar force is
the planned pull with a proportional speed droop ``δ`` = :data:`LOAD_DROOP`:
``F_load = F_plan(t) (1 + sgn(F_plan) (v − v_ref)/(δ v_ref))`` (in a braking test the load pushes,
``F_plan < 0``, and must still pull back when the speed rises),
``F_plan = n N mu_plan − F_res(v_ref) − M a_ref``,
``mu_plan`` the effect-free curve along the creep reference (:mod:`.traction_profile`). Without
effects ``v = v_ref``; an effect that changes the tractive effort by a fraction f shifts the speed by
about ``δ f v_ref``.

**Slip controller** (the TCU; acts on noise-free signals at the nominal radius ``r0``): slip
velocity reference ``w_ref = s_ref(t) v``, feed-forward of the effect-free adhesion torque and of
the wheel's inertia along the planned profile, plus PI on the slip velocity:

    T = N r0 mu_nom(s_ref, s_ref v_ref) + (J/r0)(a_ref (1 + s_ref) + v_ref ṡ_ref) + Kp e + z,
    ż = Ki e,   e = w_ref − (ω r0 − v)

**Integration.** The wheel equation is stiff at small creep (eigenvalue ≈ slope·r²·N/(J v),
10³–10⁴ s⁻¹ at walking speed), so ROS2 runs at a fixed internal step inside ``lax.scan`` and is
sampled every ``c["period"]`` (against a 0.25 ms step the true adhesion differs by < 1e-4 in 90 %
of the samples and by at most ~0.003, at the onset of the fast slip excursions). ``c`` is the
simulator's dict of traced constants (:func:`.simulator.simulate`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from ..models import effects as fx
from ..models.kinematics import creepage
from ..models.polach import polach_adhesion
from .rosenbrock import ros2_step
from .traction_profile import creep_ref, speed_ref
from .vehicle import GRAVITY

#: Slip-velocity PI gains Kp [N·m·s/m], Ki [N·m/m]: critically damped, ω_n ≈ 20 rad/s past the peak.
KP = 2.0e5
KI = 2.0e6
#: Speed droop of the speed-regulated test load [-]; Davis resistance c0 [-], c2 [N·s²/m²].
LOAD_DROOP = 0.1
ROLLING_RESISTANCE = 1.5e-3
AERO_DRAG = 6.0
#: Fixed-point steps closing the load-transfer loop (axle load → Hertz → mu → inertial force → axle
#: load). Each step shrinks the error by ``m (h_g/h_c) mu |d ln mu/d ln k_eps|/3`` ≤ 0.1 at typical
#: magnitudes (m ≤ 1.5, mu ≤ 0.4): three leave < 1e-3 of the load change.
LOAD_ITERATIONS = 3


def _resistance(v, c):
    return c["mass"] * GRAVITY * ROLLING_RESISTANCE + AERO_DRAG * v * v


def reference(t, c, prof):
    """Everything that depends on time only (hoisted out of the integrator): creep and speed
    references, the controller's feed-forward torque [N·m], the load's planned pull [N], and the
    rail-change factor."""
    s_ref, ds_ref = jax.jvp(lambda tt: creep_ref(tt, c, prof), (t,), (jnp.ones_like(t),))
    v_ref, a_ref = speed_ref(t, c)
    mu_plan = polach_adhesion(c["theta"], s_ref, s_ref * v_ref, c["k_eps"])
    t_ff = c["weight"] * c["radius"] * mu_plan + c["inertia"] / c["radius"] * (
        a_ref * (1.0 + s_ref) + v_ref * ds_ref
    )
    f_plan = c["n_axles"] * c["weight"] * mu_plan - _resistance(v_ref, c) - c["mass"] * a_ref
    rail = fx.rail_factor(c["mags"][fx.INDEX["rail_change"]], t, fx.RAIL_CHANGE_AT * c["duration"])
    return dict(s_ref=s_ref, v_ref=v_ref, t_ff=t_ff, f_plan=f_plan, rail=rail)


def controller(y, ref, c):
    """Traction torque [N·m] and slip error [m/s] of the TCU's slip-velocity controller."""
    omega, v, z, _ = y
    error = ref["s_ref"] * v - (omega * c["radius"] - v)
    return ref["t_ff"] + KP * error + z, error


def test_load(v, ref):
    """Drawbar force of the speed-regulated test load [N] at vehicle speed ``v`` [m/s]."""
    droop = jnp.sign(ref["f_plan"]) * (v - ref["v_ref"]) / (LOAD_DROOP * ref["v_ref"])
    return ref["f_plan"] * (1.0 + droop)  # a pushing load (braking, F_plan < 0) droops too


def _surface(y, ref, c):
    """True rolling radius [m], Polach parameters with the μ0 effects applied, slip [m/s], creepage [-]."""
    omega, v, _, heat = y
    m = c["mags"]
    radius = c["radius"] * (1.0 + m[fx.INDEX["wheel_radius_error"]])
    scale = (
        ref["rail"]
        * fx.speed_factor(m[fx.INDEX["speed_dependence"]], v, c["v_mean"])
        * fx.thermal_factor(m[fx.INDEX["thermal_softening"]], heat)
    )
    theta = jnp.where(jnp.arange(5) == 2, c["theta"] * scale, c["theta"])
    slip = omega * radius - v
    return radius, theta, slip, creepage(slip, v)


def _adhesion(theta, s, slip, n1, c):
    """Polach adhesion [-] at axle load ``n1`` [N] (Hertz: ``k_eps ∝ N1^(−1/3)``)."""
    return polach_adhesion(theta, s, slip, c["k_eps"] * (n1 / c["weight"]) ** (-1.0 / 3.0))


def leading_axle_load(y, ref, c):
    """Weight on the measured (leading) axle [N] under load transfer
    (:func:`..models.effects.load_factor`): the drawbar pull is the test load's, the inertial force
    comes from the locomotive equation, ``M a + F_res = n mu N − F_load``, and ``mu`` depends on the
    axle load through Hertz; :data:`LOAD_ITERATIONS` fixed-point steps from the static load close
    the loop."""
    _, theta, slip, s = _surface(y, ref, c)
    weight = c["mass"] * GRAVITY
    drawbar = test_load(y[1], ref) / weight

    def step(_, n1):
        inertial = c["n_axles"] * _adhesion(theta, s, slip, n1, c) * c["weight"] / weight - drawbar
        factor = fx.load_factor(c["mags"][fx.INDEX["load_transfer"]], drawbar, inertial, c["height_ratio"])
        return c["weight"] * factor

    return jax.lax.fori_loop(0, LOAD_ITERATIONS, step, c["weight"], unroll=True)


def contact(y, ref, c, pitch: bool):
    """True slip [m/s], creepage [-], adhesion [-], leading-axle weight [N], radius [m]; ``pitch``
    (static): load transfer is on. Off, the axle keeps its static load and the program is the one
    without the fixed point (its fused arithmetic would move the last bits of every other run)."""
    radius, theta, slip, s = _surface(y, ref, c)
    n1 = leading_axle_load(y, ref, c) if pitch else c["weight"]
    return slip, s, _adhesion(theta, s, slip, n1, c), n1, radius


def _rhs(y, ref, c, pitch):
    torque, error = controller(y, ref, c)
    slip, _, mu, n1, radius = contact(y, ref, c, pitch)
    f_load = test_load(y[1], ref)
    return jnp.stack(
        [
            (torque - mu * n1 * radius) / c["inertia"],
            (c["n_axles"] * mu * c["weight"] - _resistance(y[1], c) - f_load) / c["mass"],
            KI * error,
            (mu * n1 * jnp.abs(slip) - y[3]) / fx.THERMAL_TIME_CONSTANT,
        ]
    )


def integrate(c, prof, n_samples: int, substeps: int, pitch: bool):
    """The test from its planned speed and creep at ``t = 0``: sample times [s], states ``y`` and
    references (:func:`reference`) at ``n_samples`` samples; ``substeps`` ROS2 steps a sample;
    ``pitch``: load transfer on (:func:`contact`)."""
    h = c["period"] / substeps
    t_fine = h * jnp.arange((n_samples - 1) * substeps + 1, dtype=c["duration"].dtype)
    ref = jax.vmap(lambda t: reference(t, c, prof))(t_fine)
    v0, _ = speed_ref(t_fine[0], c)
    y0 = jnp.stack([v0 * (1.0 + ref["s_ref"][0]) / c["radius"], v0, 0.0 * v0, 0.0 * v0])

    def step(y, refs):
        ref0, ref1 = refs
        y_next = ros2_step(lambda yy: _rhs(yy, ref0, c, pitch), lambda yy: _rhs(yy, ref1, c, pitch), y, h)
        return y_next, y_next

    head = jax.tree_util.tree_map(lambda a: a[:-1], ref)
    tail = jax.tree_util.tree_map(lambda a: a[1:], ref)
    _, ys = jax.lax.scan(step, y0, (head, tail))
    ys = jnp.concatenate([y0[None], ys])[::substeps]
    return t_fine[::substeps], ys, jax.tree_util.tree_map(lambda a: a[::substeps], ref)
