"""Paper 000's online identification as text: our metrics beside the paper's, verdicts on its claims,
the ablation and the baselines (the study itself: :mod:`.online`)."""

from __future__ import annotations

from ..report.text import table


def _fmt(v):
    return "never" if v is None else f"{v:.4g}"


def _verdict(claim, key, a1, a2):
    """A1 beats A2 on the median of ``key`` and fails (never converges) no more often."""
    never = "never_" + key[2:]
    ok = a1[key] is not None and (a2[key] is None or a1[key] < a2[key])
    ok = ok and a1.get(never, 0.0) <= a2.get(never, 0.0)
    tail = f" (never: A1 {100 * a1[never]:.0f} %, A2 {100 * a2[never]:.0f} %)" if never in a1 else ""
    return (
        f"  {'holds' if ok else 'DOES NOT HOLD'}: {claim} ({key}) A1 {_fmt(a1[key])} vs A2 "
        f"{_fmt(a2[key])}{tail}"
    )


def format_text(result: dict) -> str:
    """Human-readable report: ours vs the paper, verdicts on its claims, ablation and baselines."""
    keys = (
        "k_p1_1pct",
        "k_p2_1pct",
        "k_mumax_01pct",
        "k_track_change1",
        "k_track_change2",
        "fluctuation",
        "fluctuation_dry",
    )
    rows = []
    for name, m in [
        *(("alg " + k, v) for k, v in result["algorithms"].items()),
        *result["ablation"].items(),
        *(("alg " + k, v) for k, v in result["variants"].items()),
        ("rls_0.98", result["baselines"]["rls_0.98"]),
    ]:
        row = {"config": name}
        for k in keys:
            iqr = m[k + "_iqr"]
            row[k] = f"{_fmt(m[k])} [{_fmt(iqr[0])}, {_fmt(iqr[1])}]"
        rows.append(row)
    rows.append({"config": "paper (A1)", **{k: str(result["paper"].get(k, "")) for k in keys}})
    a1, a2 = result["algorithms"]["1"], result["algorithms"]["2"]
    s = result["setup"]
    lines = [
        f"Paper 000 online identification: {s['runs']} runs x {s['steps']} steps, "
        f"rails {'->'.join(s['rails'])}, noise sigma {s['noise_sigma']}; median [IQR], "
        "'never' = more runs failed than the quantile allows",
        table(rows, ["config", *keys]),
        "Paper's claims (A1 alone, then A1 vs A2):",
    ]
    for k in ("k_p1_1pct", "k_p2_1pct", "k_mumax_01pct"):
        ours = a1[k]
        ok = ours is not None and ours <= 1.2 * result["paper"][k]
        lines.append(
            f"  {'holds' if ok else 'DOES NOT HOLD'}: {k} paper {result['paper'][k]}, "
            f"ours {_fmt(ours)} (never in {100 * a1['never_' + k[2:]]:.0f} % of runs; "
            f"first reached {_fmt(a1[k + '_first'])})"
        )
    lines += [
        _verdict(claim, key, a1, a2)
        for claim, key in (
            ("faster convergence of p2", "k_p2_1pct"),
            ("faster tracking, dry->normal", "k_track_change1"),
            ("faster tracking, normal->wet", "k_track_change2"),
            ("smaller fluctuation, RMS rel. mu_m error, all segments", "fluctuation"),
            ("smaller fluctuation, dry segment only", "fluctuation_dry"),
        )
    ]
    b = result["baselines"]["batch_ls"]
    lines.append(
        "Batch LS per segment ("
        + ", ".join(b["segments"])
        + "): median rel. error p1 "
        + ", ".join(f"{v:.2g}" for v in b["p1_relerr"])
        + "; p2 "
        + ", ".join(f"{v:.2g}" for v in b["p2_relerr"])
    )
    return "\n".join(lines)
