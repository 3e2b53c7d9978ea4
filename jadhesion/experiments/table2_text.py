"""Paper 001, Table 2 as text: our medians beside the paper's numbers, then the mcmc rows' interval
widths (the table itself: :mod:`.table2`)."""

from __future__ import annotations

from ..report.text import table


def format_text(result) -> str:
    """Table 2 as text, our medians beside the paper's numbers (with realistic-sensor rows, a
    ``sensors`` column, ``mu0`` and the status of each row)."""
    both = len(result.get("sensors", ["clean"])) > 1
    lines = [
        f"Paper 001, Table 2 — medians over {result['seeds']} seeds; target = "
        f"{result['target']}; population size {result['pop_size']}.",
        "",
    ]
    rows = []
    for r in result["rows"]:
        paper = r["paper"] or {}
        rows.append(
            {
                "scenario": r["scenario"],
                "method": r["method"],
                "floor": r["floor"],
                "error": r["error"],
                "reached": f"{100 * r['reached']:.0f}%",
                "iter": "-" if r["iterations"] is None else f"{r['iterations']:.0f}",
                "evals": "-" if r["evaluations"] is None else f"{r['evaluations']:.0f}",
                "ms": "-" if r["seconds"] is None else f"{1e3 * r['seconds']:.1f}",
                "paper err": paper.get("error", "-"),
                "paper iter": paper.get("iterations", "-"),
                "paper s": paper.get("seconds", "-"),
                "sensors": r.get("sensors", "clean"),
                "mu0": f"{r['params']['mu0']:.4f}",
                "status": r.get("status", "-"),
            }
        )
    cols = [
        "scenario",
        "method",
        "floor",
        "error",
        "reached",
        "iter",
        "evals",
        "ms",
        "paper err",
        "paper iter",
        "paper s",
    ]
    if both:
        cols = ["sensors", *cols[:5], "mu0", "status", *cols[5:]]
    lines.append(table(rows, cols))
    mc = [r for r in result["rows"] if r["method"] == "mcmc"]
    if mc:
        info = result.get("mcmc", {})
        lines += [
            "",
            f"mcmc: emcee posterior of seed 0 ({info.get('likelihood', mc[0].get('likelihood'))} "
            f"likelihood, {mc[0]['walkers']} walkers); error = MAE of the posterior "
            f"medians; iter/evals/ms = steps/log-density evaluations/time of a converged "
            f"chain (burn-in + 50 tau); 90 % interval widths:",
        ]
        names = ["kA", "kS", "mu0", "A", "B", "mu_max", "creep_opt"]
        lines.append(
            table(
                [
                    {
                        "sensors": r.get("sensors", "clean"),
                        "scenario": r["scenario"],
                        **{n: r["width90"][n] for n in names},
                        "tau": "-" if r["tau_max"] is None else f"{r['tau_max']:.0f}",
                        "converged": "yes"
                        if r["converged"]
                        else ("estimate" if r["tau_max"] is not None else "did not mix"),
                    }
                    for r in mc
                ],
                [*(["sensors"] if both else []), "scenario", *names, "tau", "converged"],
            )
        )
    return "\n".join(lines)
