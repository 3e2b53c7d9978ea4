"""One sentence per finding, in a traction engineer's terms."""

from __future__ import annotations

from ..data.vehicle import GRAVITY, Vehicle


def _effect_sentence(name: str, p: dict, vehicle: Vehicle) -> str:
    r = vehicle.wheel_radius_m
    if name == "rail_change":
        word = "dropped" if p["drop"] > 0 else "rose"
        return (
            f"the rail condition changed at t ≈ {p['t_change_s']:.1f} s: the "
            f"friction level μ0 {word} by {abs(p['drop']):.0%} (a contaminated or cleaned section); "
            "identify the two stretches separately"
        )
    if name == "wheel_radius_error":
        d = p["delta_r"]
        side = "larger" if d > 0 else "smaller"
        return (
            f"the wheel's rolling radius is {abs(d):.1%} {side} than the nominal {r:.3f} m "
            f"(≈ {r * (1 + d):.3f} m): the recorded wheel speed and the "
            "torque-to-force conversion use the nominal radius, which shifts the creep in "
            "proportion to speed; measure the wheel diameter or calibrate it on a coasting run"
        )
    if name == "signal_delay":
        return (
            f"the torque signal lags the speed signals by {1e3 * p['delay_s']:.0f} ms: the "
            "observer mixes torque and wheel acceleration from different instants; align the "
            "signals before identifying"
        )
    if name == "speed_dependence":
        return (
            f"the friction level falls by {p['slope']:.0%} per 100 % speed increase about the "
            "mean speed (Curtius–Kniffler-like); identify per speed band or add a speed term"
        )
    if name == "torque_offset":
        bias = p["offset"] * vehicle.axle_load_kg * GRAVITY * r
        return (
            f"the torque signal carries a bias of {bias / 1e3:+.1f} kN·m "
            f"({p['offset']:+.3f} in adhesion units); re-zero it on a coasting run"
        )
    if name == "thermal_softening":
        return (
            "friction softens with recent frictional power: "
            f"μ0/(1 + {p['softening']:.2f}·P/10 kW) with a thermal lag of about "
            f"{p.get('tau_th_s', float('nan')):.1f} s"
        )
    if name == "load_transfer":
        return (
            f"the measured axle's load changes with the locomotive's pitch: N(1 − {p['load_m']:.2f}·"
            f"F_t/(M g) − {p.get('load_accel', 0.0):.2f}·a/g) (tractive effort and acceleration); "
            "correct the axle load for load transfer"
        )
    raise ValueError(name)


def _blind_spots(sensitivity: dict) -> str:
    """The effects this recording cannot see at their typical magnitudes, with the exposing run."""
    blind = [(n, s) for n, s in sensitivity.items() if not s["visible"]]
    if not blind:
        return ""
    return (
        " This recording cannot show these effects at their typical size; runs that would: "
        + "; ".join(f"{n.replace('_', ' ')} — {s['experiment']}" for n, s in blind)
        + "."
    )


def explain(result: dict, vehicle: Vehicle) -> str:
    """The diagnosis in words: the verdict, what it means, the fit's improvement, ambiguities and
    the effects this recording cannot see."""
    base, extended = result["base"], result["extended"]
    if not result["effects"]:
        best = result["candidates"][0]
        p = best.get("p_value")
        text = (
            "The Polach model explains this recording: no catalogue effect lowers the held-out "
            "error beyond the calibrated threshold and beyond what clean re-synthesised "
            f"versions of this recording show (best candidate {best['name']}, "
            f"{best['gain']:+.1%}" + ("" if p is None else f", p = {p:.2f}") + ")."
        )
        if result["generic"]["used"]:
            text += (
                " Residual structure remains that no catalogue effect explains; it follows "
                f"{result['strongest_signal']} most closely, and a sparse discrepancy term "
                f"lowers the held-out error by {result['generic']['gain']:.1%}."
            )
        return text + _blind_spots(result["sensitivity"])
    parts = [_effect_sentence(n, extended["params"], vehicle) for n in result["effects"]]
    text = "; and ".join(parts)
    text = (
        text[0].upper()
        + text[1:]
        + (
            f". Modelling it lowers the held-out adhesion error from {base['heldout_mae']:.4f} to "
            f"{extended['heldout_mae']:.4f}."
        )
    )
    if result["indistinguishable"]:
        alts = ", ".join(
            f"{d['name']} (separate with {d['experiment']})" for d in result["indistinguishable"]
        )
        text += f" This recording cannot rule out: {alts}."
    return text + _blind_spots(result["sensitivity"])
