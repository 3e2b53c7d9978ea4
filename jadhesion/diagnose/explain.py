"""The diagnosis in words, one sentence per finding in a traction engineer's terms (each effect's
sentence is the effect registry's template, :data:`jadhesion.models.effects.EFFECTS`)."""

from __future__ import annotations

from ..data.vehicle import GRAVITY, Vehicle
from ..models.effects import EFFECTS


def effect_sentence(name: str, params: dict, vehicle: Vehicle) -> str:
    """The registry's sentence for effect ``name`` (:meth:`.EffectSpec.explain`) rendered with the
    fitted ``params`` and the vehicle's wheel radius and axle load."""
    context = {
        "wheel_radius_m": vehicle.wheel_radius_m,
        "axle_load_kg": vehicle.axle_load_kg,
        "gravity": GRAVITY,
    }
    return EFFECTS[name].explain({**params, **context})


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
        ranked = [c for c in result["candidates"] if c["status"] == "converged"]
        best = (ranked or result["candidates"])[0]
        p = best.get("p_value")
        strong = [n for w in result.get("warnings", []) for n in w.get("above_critical", [])]
        misfit = result["generic"]["used"]
        if strong:
            opening = (
                "The verdict is open: the fits of "
                + ", ".join(n.replace("_", " ") for n in strong)
                + " did not converge, yet lowered the error beyond what clean re-synthesised "
                "versions of this recording show; among the converged candidates, "
            )
        elif misfit:
            opening = "The Polach model does not explain this recording, and "
        else:
            opening = "The Polach model explains this recording: "
        text = (
            opening + "no catalogue effect lowers the held-out "
            "error beyond the calibrated threshold and beyond what clean re-synthesised "
            f"versions of this recording show (best {'converged ' if ranked else ''}candidate "
            f"{best['name']}, "
            f"{best['gain']:+.1%}" + ("" if p is None else f", p = {p:.2f}") + ")."
        )
        if misfit:
            text += (
                " Residual structure remains that no catalogue effect explains; it follows "
                f"{result['strongest_signal']} most closely, and a sparse discrepancy term "
                f"lowers the held-out error by {result['generic']['gain']:.1%}: physics outside "
                "the catalogue, or an adhesion curve whose shape Polach's model cannot take."
            )
        return text + _blind_spots(result["sensitivity"])
    parts = [effect_sentence(n, extended["params"], vehicle) for n in result["effects"]]
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
    if result["generic"]["used"]:
        text += (
            f" Residual structure remains after it, following {result['strongest_signal']} most "
            f"closely: a sparse discrepancy term lowers the held-out error by a further "
            f"{result['generic']['gain']:.1%}."
        )
    return text + _blind_spots(result["sensitivity"])
