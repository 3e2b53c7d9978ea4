"""Wheelset + train dynamics, driving profiles, traction controller and concealed effects.

State ``(ω, v)``: wheelset angular speed [rad/s] and train speed [m/s], all axles alike:

    J ω̇ = T − F·r_true,      (M_loco + M_trail) v̇ = n F − R(v) − (M_loco + M_trail) g·grade,

``F = mu_adh(s, w)·Q_axle`` [N] the adhesion force of one axle, ``w = ω r_true − v``,
``s = w / sqrt(v² + V_FLOOR²)`` (this generator's standstill guard), ``R`` a Davis resistance
(15 + 0.36 v + 0.039 v² N per tonne, the constant term signed by tanh(v/0.05)). Creep dynamics are
stiff (eigenvalues up to ~1e5 /s near standstill), so each internal step (≤ 2 ms) is **backward
Euler with Newton iterations** on ``(ω, v)`` (numerical 2×2 Jacobian): L-stable, no NaN at any speed.
The slow states (thermal power, load-transfer fraction) follow exact first-order updates per step.

**Controller** (stateless, on the noise-free nominal-radius slip ``w_m = ω r_nom − v``):
``T = clip(T_cmd − K (w_m − w_lim)⁺ + K (−w_m − w_lim)⁺, ±T_max)`` with ``K = 20 Q_axle r_nom`` N·m
per m/s: below the peak the torque command acts directly; past it the slip limiter holds the slip
near ``w_lim``, so a rising torque with a sweeping ``w_lim`` walks the falling branch. Guards: the
command fades above ``V_CAP``, braking fades below 1 m/s, and below 1 m/s the driver keeps at least
half the reference torque (no roll-back).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .physics import GRAVITY, ForeignVehicle, polach

V_FLOOR = 0.02  # m/s, creepage guard at standstill
V_CAP = 14.0  # m/s, speed above which the torque command fades out
LIMITER_GAIN = 20.0  # slip-limiter gain in adhesion units per m/s (times Q_axle r_nom → N·m/(m/s))
THERMAL_TAU_S, THERMAL_POWER_W = 4.0, 5.0e4  # thermal_softening lag [s] and reference power [W]
PITCH_TAU_S = 0.2  # s, lag of the load transfer (suspension pitch)


@dataclasses.dataclass(frozen=True)
class Effect:
    """A concealed effect: magnitude unit, typical |magnitude| range, whether its sign varies."""

    unit: str
    low: float
    high: float
    signed: bool
    doc: str


EFFECTS = {
    "none": Effect("-", 0.0, 0.0, False, "nothing concealed"),
    "rail_change": Effect(
        "relative",
        0.15,
        0.40,
        True,
        "mu0 → mu0(1+m) at a time in 35–65 % of the run; kA → kA(1+m/2) on half the runs",
    ),
    "wheel_radius_error": Effect(
        "relative", 0.005, 0.02, True, "true rolling radius r_nom(1+m); wheel speed logged at r_nom"
    ),
    "signal_delay": Effect("s", 0.05, 0.30, False, "logged torque is the torque m seconds earlier"),
    "speed_dependence": Effect(
        "-",
        0.4,
        1.0,
        False,
        "mu0(v) = mu0((1−m) + m·CK(v)/CK(0)), Curtius–Kniffler CK = 7.5/(3.6v + 44) + 0.161",
    ),
    "torque_offset": Effect("adhesion units", 0.01, 0.04, True, "logged torque + m·Q_axle·r_nom [N·m]"),
    "thermal_softening": Effect(
        "-", 0.1, 0.4, False, "mu0·exp(−m·P̄/50 kW), P̄ = frictional power F|w| lagged 4 s"
    ),
    "load_transfer": Effect(
        "-",
        0.1,
        0.4,
        True,
        "Q_axle(1+q), q → m(h_c F_coupler + h_g M_loco v̇)/(h_g M_loco g), lag 0.2 s; k_eps ∝ (1+q)^(−1/3)",
    ),
}


def random_effect(name: str, rng: np.random.Generator, duration: float) -> tuple:
    """A magnitude in the typical range (random sign where signed) and the effect's details."""
    spec = EFFECTS[name]
    magnitude = float(rng.uniform(spec.low, spec.high)) * (rng.choice([-1, 1]) if spec.signed else 1)
    return magnitude, effect_detail(name, magnitude, rng, duration)


def effect_detail(name: str, magnitude: float, rng: np.random.Generator, duration: float) -> dict:
    """Random details of an effect beyond its magnitude (only rail_change has any)."""
    if name != "rail_change":
        return {}
    return {
        "time_s": float(rng.uniform(0.35, 0.65) * duration),
        "ka_factor": float(1.0 + magnitude / 2.0) if rng.random() < 0.5 else 1.0,
    }


@dataclasses.dataclass(frozen=True)
class Plan:
    """A driving profile: piecewise-linear torque command and slip limit, initial speed, train."""

    kind: str
    knots_s: tuple  # knot times [s]
    torque_frac: tuple  # torque command at the knots, in units of the reference mu0·Q_axle·r_nom
    slip_limit: tuple  # slip limit w_lim at the knots [m/s]
    v0: float  # initial speed [m/s]
    trailing_mass_kg: float
    grade: float  # rise over run [-], positive uphill


PROFILES = ("start", "sweep", "steady")
_WEIGHTS = {
    "start": {"sweep": 2, "ramp": 2, "hold": 1, "excursion": 1, "coast": 1.5},
    "sweep": {"sweep": 3, "ramp": 2, "hold": 0.5, "coast": 1.5},
    "steady": {"hold": 2, "excursion": 2, "coast": 1.5, "brake": 1, "ramp": 1},
}


def make_plan(kind: str, rng: np.random.Generator, duration: float) -> Plan:
    """A random profile of ``kind`` (:data:`PROFILES`): starting pull from standstill, creep sweeps
    from a rolling start, or steady pulls with slip excursions and braking; all with coasting gaps."""
    knots = [(0.0, 0.0, 0.3)]

    def go(dt, frac, wlim):
        knots.append((knots[-1][0] + dt, frac, wlim))

    if kind == "start":
        go(rng.uniform(4, 6), rng.uniform(1.0, 1.2), rng.uniform(0.1, 0.3))
        go(rng.uniform(3, 6), knots[-1][1], knots[-1][2])
    names = sorted(_WEIGHTS[kind])
    weights = np.array([_WEIGHTS[kind][n] for n in names], float)
    while knots[-1][0] < duration:
        level = knots[-1][1]
        segment = names[rng.choice(len(names), p=weights / weights.sum())]
        if segment == "sweep":  # slip limit swept up past the peak and back at a high command
            go(0.8, rng.uniform(1.15, 1.4), 0.005)
            go(rng.uniform(4, 9), knots[-1][1], rng.uniform(0.3, 1.0))
            go(rng.uniform(4, 9), knots[-1][1], 0.005)
            go(1.0, rng.uniform(0.3, 0.6), 0.3)
        elif segment == "ramp":  # torque ramped up (maybe past the peak) and back down
            go(rng.uniform(3, 8), rng.uniform(0.7, 1.3), rng.uniform(0.1, 0.4))
            go(rng.uniform(3, 8), rng.uniform(0.1, 0.4), knots[-1][2])
        elif segment == "hold":
            go(1.0, rng.uniform(0.3, 0.8), 0.3)
            go(rng.uniform(3, 8), knots[-1][1], 0.3)
        elif segment == "excursion":  # short burst past the peak
            go(0.5, rng.uniform(1.2, 1.5), rng.uniform(0.2, 0.6))
            go(rng.uniform(1, 2), knots[-1][1], knots[-1][2])
            go(0.5, level, 0.3)
            go(rng.uniform(1, 3), level, 0.3)
        elif segment == "coast":
            go(0.5, 0.0, 0.3)
            go(rng.uniform(2, 5), 0.0, 0.3)
        else:  # brake
            go(1.0, -rng.uniform(0.4, 1.2), rng.uniform(0.1, 0.4))
            go(rng.uniform(1, 3), knots[-1][1], knots[-1][2])
            go(1.0, 0.0, 0.3)
    t, frac, wlim = zip(*knots, strict=True)
    v0 = {"start": 0.0, "sweep": rng.uniform(1.0, 8.0), "steady": rng.uniform(2.0, 10.0)}[kind]
    trailing = rng.uniform(500e3, 2500e3) if kind == "start" else rng.uniform(300e3, 2000e3)
    return Plan(kind, t, frac, wlim, float(v0), float(trailing), float(rng.uniform(-0.002, 0.004)))


@dataclasses.dataclass
class World:
    """Everything the right-hand side needs (constants for one run)."""

    vehicle: ForeignVehicle
    params: dict
    plan: Plan
    effect: str
    magnitude: float
    detail: dict

    def __post_init__(self):
        v = self.vehicle
        self.r_nom = v.wheel_radius_m
        self.r_true = v.wheel_radius_m * (1.0 + self.magnitude * (self.effect == "wheel_radius_error"))
        self.q_axle = v.axle_weight_n
        self.k_eps = v.k_eps()
        self.t_ref = self.params["mu0"] * self.q_axle * self.r_nom
        self.gain = LIMITER_GAIN * self.q_axle * self.r_nom
        self.m_total = v.locomotive_mass_kg + self.plan.trailing_mass_kg
        self.knots = np.asarray(self.plan.knots_s)
        self.fracs, self.wlims = np.asarray(self.plan.torque_frac), np.asarray(self.plan.slip_limit)


def _resistance(mass_kg, v):
    """Davis running resistance [N] of ``mass_kg`` at speed v [m/s]."""
    return mass_kg / 1000.0 * (15.0 * math.tanh(v / 0.05) + 0.36 * v + 0.039 * v * abs(v))


def command(world: World, t) -> tuple:
    """The plan's torque command [units of the reference torque] and slip limit [m/s] at t [s]."""
    return float(np.interp(t, world.knots, world.fracs)), float(np.interp(t, world.knots, world.wlims))


def torque(world: World, cmd, omega, v):
    """Traction torque at the wheelset [N·m] from the controller (module docstring)."""
    frac, wlim = cmd
    if frac > 0:
        frac *= min(max(V_CAP + 1.0 - v, 0.0), 1.0)
    else:
        frac *= min(max(v - 0.5, 0.0), 1.0)
    frac = max(frac, 0.5 * min(max((1.0 - v) / 0.5, 0.0), 1.0))
    w_m = omega * world.r_nom - v
    cmd = frac * world.t_ref - world.gain * (max(w_m - wlim, 0.0) - max(-w_m - wlim, 0.0))
    return min(max(cmd, -world.vehicle.max_torque_nm), world.vehicle.max_torque_nm)


def forces(world: World, t, cmd, omega, v, heat, q):
    """(ω̇, v̇, aux) at a state; ``cmd`` from :func:`command`, ``heat`` = lagged frictional power
    [W], ``q`` = load fraction."""
    p = world.params
    mu0, ka = p["mu0"], p["kA"]
    if world.effect == "rail_change" and t >= world.detail["time_s"]:
        mu0, ka = mu0 * (1.0 + world.magnitude), min(ka * world.detail["ka_factor"], 1.0)
    elif world.effect == "speed_dependence":
        ck = (7.5 / (3.6 * abs(v) + 44.0) + 0.161) / (7.5 / 44.0 + 0.161)
        mu0 *= 1.0 - world.magnitude + world.magnitude * ck
    elif world.effect == "thermal_softening":
        mu0 *= math.exp(-world.magnitude * heat / THERMAL_POWER_W)
    w = omega * world.r_true - v
    s = w / math.sqrt(v * v + V_FLOOR * V_FLOOR)
    load = world.q_axle * (1.0 + q)
    mu = polach(s, w, ka, p["kS"], mu0, p["A"], p["B"], world.k_eps * (1.0 + q) ** (-1.0 / 3.0))
    force = mu * load
    tq = torque(world, cmd, omega, v)
    veh, plan = world.vehicle, world.plan
    resist = _resistance(world.m_total, v) + world.m_total * GRAVITY * plan.grade
    omega_dot = (tq - force * world.r_true) / veh.wheelset_inertia_kgm2
    v_dot = (veh.n_axles * force - resist) / world.m_total
    aux = (tq, force, load, mu0, s, w)
    return omega_dot, v_dot, aux


def simulate(world: World, duration: float, step: float = 2e-3) -> dict:
    """Integrate the run on a uniform internal grid of ``step`` [s]; the latent truth per step.

    Returns arrays: time [s], omega [rad/s], vehicle_speed [m/s], torque [N·m], force (adhesion
    force of one axle) [N], load (axle load) [N], mu0_eff, creep, slip [m/s], heat [W], load_frac,
    omega_dot [rad/s²], v_dot [m/s²].
    """
    n = int(math.ceil(duration / step)) + 1
    h = duration / (n - 1)
    out = {
        k: np.empty(n)
        for k in (
            "time",
            "omega",
            "vehicle_speed",
            "torque",
            "force",
            "load",
            "mu0_eff",
            "creep",
            "slip",
            "heat",
            "load_frac",
            "omega_dot",
            "v_dot",
        )
    }
    veh = world.vehicle
    omega, v, heat, q = world.plan.v0 / world.r_true, world.plan.v0, 0.0, 0.0
    decay_heat, decay_q = math.exp(-h / THERMAL_TAU_S), math.exp(-h / PITCH_TAU_S)
    for i in range(n):
        t = i * h
        if i:  # backward Euler step from t − h to t, Newton on (ω, v)
            x0, y, cmd = (omega, v), [omega, v], command(world, t)
            for _ in range(8):
                od, vd, _ = forces(world, t, cmd, y[0], y[1], heat, q)
                g0, g1 = y[0] - x0[0] - h * od, y[1] - x0[1] - h * vd
                d_om = 1e-7 * max(1.0, abs(y[0]))
                d_v = 1e-7 * max(1.0, abs(y[1]))
                o1, v1, _ = forces(world, t, cmd, y[0] + d_om, y[1], heat, q)
                o2, v2, _ = forces(world, t, cmd, y[0], y[1] + d_v, heat, q)
                j00, j10 = 1.0 - h * (o1 - od) / d_om, -h * (v1 - vd) / d_om
                j01, j11 = -h * (o2 - od) / d_v, 1.0 - h * (v2 - vd) / d_v
                det = j00 * j11 - j01 * j10
                dx0, dx1 = (g0 * j11 - g1 * j01) / det, (g1 * j00 - g0 * j10) / det
                y = [y[0] - dx0, y[1] - dx1]
                if abs(dx0) * world.r_true < 1e-10 and abs(dx1) < 1e-10:
                    break
            omega, v = y
        od, vd, (tq, force, load, mu0, s, w) = forces(world, t, command(world, t), omega, v, heat, q)
        for key, val in (
            ("time", t),
            ("omega", omega),
            ("vehicle_speed", v),
            ("torque", tq),
            ("force", force),
            ("load", load),
            ("mu0_eff", mu0),
            ("creep", s),
            ("slip", w),
            ("heat", heat),
            ("load_frac", q),
            ("omega_dot", od),
            ("v_dot", vd),
        ):
            out[key][i] = val
        heat = decay_heat * heat + (1.0 - decay_heat) * abs(force * w)
        if world.effect == "load_transfer":
            trail = world.plan.trailing_mass_kg
            coupler = trail * vd + _resistance(trail, v) + trail * GRAVITY * world.plan.grade
            target = (
                world.magnitude
                * (veh.coupler_height_m * coupler + veh.cog_height_m * veh.locomotive_mass_kg * vd)
                / (veh.cog_height_m * veh.locomotive_mass_kg * GRAVITY)
            )
            q = decay_q * q + (1.0 - decay_q) * target
    return out
