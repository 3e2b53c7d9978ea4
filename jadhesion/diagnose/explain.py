"""The diagnosis in words, one sentence per finding in a traction engineer's terms (each effect's
sentence is the effect registry's template, :data:`jadhesion.models.effects.EFFECTS`)."""

from __future__ import annotations

from ..data.vehicle import GRAVITY, Vehicle
from ..models.effects import EFFECTS, on_clock
from .select import ALPHA, MIN_REPLICAS, beyond_typical


def effect_sentence(name: str, params: dict, vehicle: Vehicle, t_start_s: float = 0.0) -> str:
    """The registry's sentence for effect ``name`` (:meth:`.EffectSpec.explain`) rendered with the
    fitted ``params``, the vehicle's wheel radius and axle load and the recording clock's first
    fitted sample ``t_start_s`` [s]."""
    context = {
        "wheel_radius_m": vehicle.wheel_radius_m,
        "axle_load_kg": vehicle.axle_load_kg,
        "gravity": GRAVITY,
        "t_start_s": t_start_s,
    }
    return EFFECTS[name].explain({**params, **context})


#: The generic discrepancy's sentence. It has no null of its own: on 16 clean recordings it passed
#: its threshold on all 8 of our simulator's (gains 5–69 %) and none of the independent
#: generator's (``diagnose_null_generic_weighted.json``), so it says where residual structure
#: lies, not that physics is missing.
_GENERIC = (
    " A sparse discrepancy term on the residual lowers the held-out error by {gain:.1%} (following "
    "{signal} most closely); it is not tested against a null, and on clean recordings it gains as "
    "much, so this alone is no evidence that physics is missing."
)


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


def _smallest_visible(sensitivity: dict) -> str:
    """After a "none" verdict: the smallest size of each effect this recording could have shown
    (``sensitivity[...].min_detectable``, the registry's units); smaller ones may be present. Where
    blind tests found such a limit optimistic (:meth:`.Detection.limit_holds`), it says so."""
    seen = [(n, s["min_detectable"]) for n, s in sensitivity.items() if s["visible"] and s["min_detectable"]]
    if not seen:
        return ""
    sizes = []
    for name, size in seen:
        unit = EFFECTS[name].unit
        sizes.append(f"{name.replace('_', ' ')} {size:.3g}{'' if unit == '-' else ' ' + unit}")
    text = (
        " The smallest sizes this recording could have shown (the effects' magnitudes): "
        + ", ".join(sizes)
        + "; smaller ones may be present."
    )
    weak = [EFFECTS[n] for n, _ in seen if EFFECTS[n].detection.limit_holds() is False]
    for spec in weak:
        named, above = spec.detection.own_limit
        text += (
            f" The {spec.name.replace('_', ' ')} limit is optimistic: in blind tests an effect above "
            f"such a limit was named in {named} of {above} cases."
        )
    return text


def _improvement(result: dict) -> str:
    """What modelling the verdict gains: the cross-validated error where it falls; otherwise the
    in-sample SSE reduction and ΔBIC that named it (:mod:`.select`), and why the folds disagree."""
    base, extended = result["base"], result["extended"]
    if extended["heldout_mae"] < base["heldout_mae"]:
        return (
            f". Modelling it lowers the cross-validated error (weighted mean |residual| of μ on "
            f"held-out stretches) from {base['heldout_mae']:#.3g} to {extended['heldout_mae']:#.3g}."
        )
    first = next(c for c in result["candidates"] if c["name"] == result["effects"][0])
    return (  # round 1's numbers are the first effect's alone: it is named
        f". Modelling {first['name'].replace('_', ' ')} lowers the squared error by "
        f"{first['sse_reduction']:.0%} (ΔBIC {first['delta_bic']:.1f}); the cross-validated error does "
        f"not fall ({base['heldout_mae']:#.3g} → {extended['heldout_mae']:#.3g}): a held-out stretch asks "
        "the fit to extrapolate to creep, speed or heat the other stretches did not see."
    )


def _refit(result: dict) -> str:
    """Where round 2 found a better optimum of the first effect than round 1
    (``second_round.first_refit``): the candidate table's numbers are round 1's, the model's not."""
    second = result.get("second_round") or {}
    refit = second.get("first_refit")
    if not refit or result["effects"][:1] != [second["first"]]:
        return ""
    name, other = second["first"].replace("_", " "), refit["from_pair_with"].replace("_", " ")
    use = (
        "the values above are that refit's"
        if len(result["effects"]) == 1
        else "the second effect was judged against that refit"
    )
    return (
        f" Round 1's fit of {name} sat in a local optimum: refitted alone from its fit beside "
        f"{other}, it leaves {100 * refit['sse_reduction']:.2g}% less squared error than round 1's, "
        f"and {use}."
    )


def _sizes(result: dict) -> str:
    """The named effects' sizes as 90 % intervals (``extended.uncertainty``), where determined."""
    ci = result["extended"]["uncertainty"]["ci90"]
    parts = [
        f"{p} {ci[p][0]:.3g} to {ci[p][1]:.3g}"
        for p in (EFFECTS[n].magnitude_param for n in result["effects"])
        if ci.get(p) is not None
    ]
    return f" 90 % intervals, given the model: {'; '.join(parts)}." if parts else ""


def _change_time(result: dict) -> str:
    """How well the recording places a named rail change in time (``extended.change_time``)."""
    found = result["extended"].get("change_time")
    if not found:
        return ""
    start = result.get("time_start_s", 0.0)
    level = 100 * found["level"]
    text = (
        f" The change's time lies within {on_clock(found['t_change_interval_s'], start)} ({level:.0f} % "
        "profile interval)"
    )
    if not found["fit_inside"]:
        best = on_clock((found["best_t_change_s"],), start)
        text += f"; the profile fits best at {best}, not at the time above"
    return text + "."


def explain(result: dict, vehicle: Vehicle) -> str:
    """The diagnosis in words: the verdict, what it means, the fit's improvement, ambiguities and
    the effects this recording cannot see."""
    if not result["effects"]:
        ranked = [c for c in result["candidates"] if c["status"] == "converged"]
        best = (ranked or result["candidates"])[0]
        p = best.get("p_value")
        replicas = result.get("null", {}).get("replicas", 0)
        if 0 < replicas < MIN_REPLICAS:  # no p-value can reach ALPHA: 'none' is no finding
            return (
                f"No effect can be named with {replicas} replicas: the smallest p-value, "
                f"1/{replicas + 1} = {1.0 / (replicas + 1):.2f}, is above {ALPHA:g} (--replicas "
                f"{MIN_REPLICAS} at least), so the verdict 'none' is not a finding (best "
                f"{'converged ' if ranked else ''}candidate {best['name']}, {best['gain']:+.1%}"
                + ("" if p is None else f", p = {p:.2f}")
                + ")."
                + _blind_spots(result["sensitivity"])
            )
        if not ranked:  # nothing was tested: 'none' is no finding either
            return (
                "No effect can be named: no candidate's fit converged ("
                + ", ".join(f"{c['name'].replace('_', ' ')} {c['status']}" for c in result["candidates"])
                + "), so none was tested and the verdict 'none' is not a finding."
                + _blind_spots(result["sensitivity"])
            )
        strong = [n for w in result.get("warnings", []) for n in w.get("above_critical", [])]
        opening = (
            "The verdict is open: the fits of "
            + ", ".join(n.replace("_", " ") for n in strong)
            + " did not converge, yet lowered the error beyond what clean re-synthesised versions "
            "of this recording show; among the converged candidates, "
            if strong
            else "No catalogue effect is found: "
        )
        beyond = beyond_typical(result["candidates"])
        if beyond:
            text = opening + (
                " and ".join(
                    f"{c['name'].replace('_', ' ')} ({c['gain']:+.1%}"
                    + ("" if c["p_value"] is None else f", p = {c['p_value']:.2f}")
                    + ")"
                    for c in beyond
                )
                + " passed every test only at a size beyond the effect's typical range: the base model's "
                "misfit (a walking-pace start's, typically), not the effect; no other candidate "
            )
        else:
            text = opening + "no catalogue effect "
        text += "lowers the held-out error beyond the calibrated threshold" + (
            " and beyond what clean re-synthesised versions of this recording show" if replicas else ""
        )
        if not beyond:
            text += (
                f" (best converged candidate {best['name']}, "
                f"{best['gain']:+.1%}" + ("" if p is None else f", p = {p:.2f}") + ")"
            )
        text += "."
        if result["generic"]["used"]:
            text += _GENERIC.format(signal=result["strongest_signal"], gain=result["generic"]["gain"])
        return text + _smallest_visible(result["sensitivity"]) + _blind_spots(result["sensitivity"])
    start = result.get("time_start_s", 0.0)
    parts = [effect_sentence(n, result["extended"]["params"], vehicle, start) for n in result["effects"]]
    text = "; and ".join(parts)
    text = text[0].upper() + text[1:] + _improvement(result) + _sizes(result) + _refit(result)
    text += _change_time(result)
    if result["indistinguishable"]:
        alts = ", ".join(
            f"{d['name']} (separate with {d['experiment']})" for d in result["indistinguishable"]
        )
        text += f" This recording cannot rule out: {alts}."
    if result["generic"]["used"]:
        text += _GENERIC.format(signal=result["strongest_signal"], gain=result["generic"]["gain"])
    return text + _blind_spots(result["sensitivity"])
