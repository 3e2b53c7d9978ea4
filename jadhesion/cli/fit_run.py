"""``jadhesion fit``'s work: load, observe, fit, report how far to trust it (arguments: :mod:`.fit`).

One file gives today's document; several files (or a directory) give ``{"fits": [...]}``, one
single-fit document per file with its ``file``. Every file is loaded and checked before any fit
(a bad one: exit 2, one line naming it, nothing written). Fits (Polach and Kiencke) go through
:func:`jadhesion.identify.batch_fit.fit_datasets`: each dataset padded to its length bucket, one
compiled program per method and bucket (Polach's kept, :mod:`.fit_program`) — a lone file takes
the same path, so its result is the same whether it is fitted alone or with others.

Each document also says what was fitted against: ``vehicle`` (the vehicle numbers used, the
sidecar's or 22E's defaults) and, first in ``warnings``, what is wrong with the recording itself
(unknown sidecar keys, also said on stderr at once; speed columns that look swapped).
"""

from __future__ import annotations

import csv
import io
import sys
from pathlib import Path

import numpy as np

from ..atomic import atomic_write
from ..data.dataset import sd_scale_summary
from ..data.formats import RECORDING_SUFFIXES
from ..data.length_buckets import bucket_length
from ..data.selected import creep_sign_warning, stuck_speed_warning
from ..data.sidecar import sidecar_warning
from ..identify.batch_fit import bucketed, fit_datasets
from ..identify.kiencke_fit import fit_document, fit_kiencke
from ..identify.likelihood import other_slip_law
from ..identify.methods import METHODS
from ..identify.polach_fit import MIN_SAMPLES, RECOMMENDED_SAMPLES, require_samples, scaled
from ..identify.trust import fit_report, join_slip_laws
from ..memory_maps import release_if_near_limit
from ..models.polach import PARAM_NAMES
from ..status import status_of
from .common import (
    MAX_ITER,
    UserError,
    emit_json,
    require_at_least,
    require_in_range,
    require_output_dir,
    require_output_file,
    require_population_memory,
    require_seed,
    say_written,
    table,
)
from .fit_program import fit_polach, seed_key, slip_nodes, to_dataset, trust_numbers
from .loading import load_dataset, load_from_args, say_notes_and_sidecar_warning, slip_law_used


def _given_budget(args) -> dict:
    """The population-budget flags given on the command line (``pop_size``, ``max_iter``)."""
    return {k: getattr(args, k) for k in ("pop_size", "max_iter") if getattr(args, k) is not None}


def _budget(args) -> dict:
    """``--pop-size``/``--max-iter`` as the method's keyword arguments, the registry's defaults
    where not given (:data:`.methods.METHODS`); for a method without them (LM stops at its own
    convergence test, capped inside the fit) they are left out."""
    defaults = METHODS[args.method].defaults
    return {**defaults, **{k: v for k, v in _given_budget(args).items() if k in defaults}}


def _ignored_budget(args) -> str | None:
    """The warning for budget flags the method has none of (said, not silently dropped: a script
    may pass one set of flags to every method)."""
    defaults = METHODS[args.method].defaults
    stray = [f"--{k.replace('_', '-')}" for k in _given_budget(args) if k not in defaults]
    if not stray:
        return None
    return (
        f"{' and '.join(stray)} set a population method's budget (itlbo, tlbo, pso) and are ignored: "
        f"--method {args.method} stops at its own convergence test"
    )


def _check_flags(args) -> None:
    require_seed("fit", args.seed)
    require_at_least("fit", 2, pop_size=args.pop_size)
    require_in_range("fit", 1, MAX_ITER, max_iter=args.max_iter)
    if (note := _ignored_budget(args)) is not None:
        sys.stderr.write(f"jadhesion: warning: {note}\n")
    if args.plot is not None and args.model == "kiencke":  # said, as the budget flags: never silent
        sys.stderr.write("jadhesion: warning: --plot draws Polach fits only: no figure for --model kiencke\n")
    if args.single_law and args.model == "kiencke":
        sys.stderr.write("jadhesion: warning: --single-law has no effect with --model kiencke\n")
    require_output_dir("fit", "plot", args.plot)
    if args.out is not None:
        require_output_file("fit", args.out)


# ---- which files ------------------------------------------------------------------------------


def expand_files(names) -> tuple[list[Path], bool]:
    """The recordings named (a directory stands for its text, Parquet and MATLAB files, sorted:
    :data:`~jadhesion.data.formats.RECORDING_SUFFIXES`) and
    whether the call is a many-file one (more than one name, or a directory)."""
    paths, many = [], len(names) > 1
    for name in names:
        p = Path(name)
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in RECORDING_SUFFIXES)
            if not found:
                raise UserError(f"fit: {p}: directory holds no recording ({', '.join(RECORDING_SUFFIXES)})")
            paths += found
            many = True
        else:
            paths.append(p)
    return paths, many


def _check_out_is_no_input(args, paths) -> None:
    """``--out`` naming one of the recordings fitted is refused before any work: the table
    silently replaced the recording."""
    if args.out is None or not Path(args.out).exists():
        return
    for path in paths:
        if path.exists() and path.samefile(args.out):
            raise UserError(f"fit: --out {args.out}: is the recording {path}; it would be overwritten")


def _check_figure_names(args, paths, many: bool) -> None:
    """Several files with ``--plot``: each writes ``STEM.fit.png``, so two with one stem (``a.csv``
    and ``a.parquet``, or ``x/a.csv`` and ``y/a.csv``) are refused before any work; the second
    figure silently replaced the first."""
    if args.plot is None or args.model != "polach" or not many:
        return
    seen = {}
    for path in paths:
        if path.stem in seen:
            raise UserError(
                f"fit: --plot {args.plot}: {seen[path.stem]} and {path} would both write "
                f"{path.stem}.fit.png; give each file once, and rename or fit apart files that share a name"
            )
        seen[path.stem] = path


def _load(args, path):
    """``(dataset, selection, report)`` of one file: :func:`.loading.load_dataset` after a row
    count check that names no model (it serves Polach and Kiencke fits, before any observer work);
    :func:`require_samples` then counts the samples the selection kept; ``report`` what the fit's
    document says of the recording itself (:func:`_recording_report`). Unknown sidecar keys are
    said on stderr at once, before anything they may explain goes wrong."""
    recording = load_from_args(args, path)
    say_notes_and_sidecar_warning(recording)
    rows = recording.n_samples
    if rows < MIN_SAMPLES:
        raise UserError(
            f"{path}: {rows} samples cannot identify the model "
            f"(at least {MIN_SAMPLES} needed, {RECOMMENDED_SAMPLES} recommended)"
        )
    _, dataset, selection = load_dataset(args, path, to_dataset, recording=recording)
    if args.model == "polach" and dataset.slip_sd is not None:  # Kiencke has no slip law
        dataset = slip_nodes(dataset, args.slip_law)  # either law's: one fit program for both
    require_samples(dataset, str(path))
    release_if_near_limit()  # programs are per length bucket; many buckets still add up
    return dataset, selection, _recording_report(recording, selection)


#: The vehicle numbers a fit's document echoes (``vehicle``): μ̂ scales with the axle load and
#: wheel radius, the observer with the inertia.
VEHICLE_KEYS = ("name", "axle_load_kg", "wheel_radius_m", "wheelset_inertia_kgm2")


def _recording_report(recording, selection) -> dict:
    """``vehicle`` {:data:`VEHICLE_KEYS`} (the sidecar's, else 22E's defaults), ``warnings``
    ``{code, params, message}`` about the recording rather than the fit: unknown sidecar keys
    (:func:`jadhesion.data.sidecar.sidecar_warning`), most moving samples with the creep against
    the drive (:func:`jadhesion.data.selected.creep_sign_warning`), a stuck or clipped speed
    (:func:`jadhesion.data.selected.stuck_speed_warning`); the reader's ``notes``
    (:func:`.loading.say_notes`); and whether it has the raw signals (``raw_signals``: else its
    creep is the file's own, ``creep`` "given")."""
    found = (
        sidecar_warning(recording),
        creep_sign_warning(recording, selection),
        stuck_speed_warning(recording),
    )
    return {
        "vehicle": {k: getattr(recording.vehicle, k) for k in VEHICLE_KEYS},
        "warnings": [w for w in found if w is not None],
        "notes": list(recording.notes),
        "raw_signals": recording.has_raw_signals,
    }


def _check_population(args, paths, datasets) -> None:
    """A population method's ``--pop-size`` within :data:`.common.MAX_POPULATION_BYTES` on every
    dataset, padded to its length bucket as it is fitted (``--pop-size 10**8`` asked XLA for
    844 GB and ended in a RESOURCE_EXHAUSTED traceback)."""
    pop_size = _budget(args).get("pop_size")
    if pop_size is None:
        return
    for path, dataset in zip(paths, datasets, strict=True):
        n = int(dataset.adhesion.shape[-1])
        require_population_memory("fit", pop_size, bucket_length(n), f"on {path} ({n} samples)")


# ---- fits -------------------------------------------------------------------------------------


def _describe(doc) -> str:
    """The trust block in words."""
    lines = []
    if not doc["converged"]:
        lines.append(f"NOT CONVERGED: the solver stopped with status {doc['status']}")
    else:
        lines.append("converged")
    rows = []
    on_bound = {n for w in doc["warnings"] if w["code"] == "at_bound" for n in w["params"]}
    for name, value in doc["params"].items():
        u = doc["uncertainty"][name]
        ci = u["ci95"]
        no_stderr = "on bound" if name in on_bound else "n/a"  # else not determined (undetermined)
        rows.append(
            {
                "parameter": name,
                "value": value,
                "stderr": no_stderr if u["stderr"] is None else u["stderr"],
                "95% interval": "-" if ci is None else f"[{ci[0]:.4g}, {ci[1]:.4g}]",
            }
        )
    lines.append(table(rows, ["parameter", "value", "stderr", "95% interval"]))
    lines.append(
        f"standard errors: the larger of Newey–West's (HAC, {doc['hac_lags']} lags: the observer's "
        f"coloured residuals) and the jackknife's over {doc['jackknife_blocks']} blocks (errors that "
        "come with stretches of the recording)"
    )
    if (check := doc.get("slip_law_check")) is not None:
        p = ", ".join(f"{k} {v:.4g}" for k, v in check["params"].items())
        lines.append(
            f"95% intervals join both slip laws' (the smoother's error Berkson or classical: one "
            f"recording cannot tell); {check['law']} law by LM: {p} ({check['status']})"
        )
    lines.append(
        f"peak of the curve at {doc['vehicle_speed']:.3g} m/s (median speed): " + _peak_text(doc["derived"])
    )
    lines += [f"warning [{w['code']}]: {w['message']}" for w in doc["warnings"]]
    return "\n".join(lines)


def _peak_text(derived) -> str:
    parts = []
    for name in ("mu_max", "creep_opt"):
        d = derived[name]
        ci = "" if d["ci95"] is None else f" [{d['ci95'][0]:.4g}, {d['ci95'][1]:.4g}]"
        parts.append(f"{name} {d['value']:.4g}{ci}")
    return ", ".join(parts)


def trust_report(dataset, fit) -> dict:
    """:func:`fit_report` of a fit, its covariance from the dataset padded to its length bucket,
    as the fit (one kept trust program per bucket: :func:`.fit_program.trust_numbers`)."""
    return fit_report(dataset, fit, numbers=trust_numbers(fit.params, scaled(bucketed(dataset), fit)))


def _params(fit) -> dict:
    return dict(zip(PARAM_NAMES, np.asarray(fit.params).tolist(), strict=True))


def _polach_doc(args, dataset, fit, seconds, check=None) -> dict:
    """One file's document (``fit.mae``/``sse`` over its own samples; the trust block from the
    unpadded dataset); ``check``: its :func:`_slip_law_checks` entry, whose intervals the trust
    block joins to its own (:func:`jadhesion.identify.trust.join_slip_laws`)."""
    status = status_of(fit.status)
    params = _params(fit)
    report = trust_report(dataset, fit)
    if check is not None:
        report = join_slip_laws(report, params, check)
    return {
        "model": "polach",
        "method": args.method,
        "params": params,
        "mae": float(fit.mae),
        "iterations": int(fit.iterations),
        "evaluations": int(fit.evaluations),
        "seconds": seconds,
        "status": status.label,
        "converged": status.converged,
        # LM's robust sd of mu_hat about the curve (its standardised residual's scale); None else
        "noise_scale": None if fit.residual_scale is None else float(fit.residual_scale),
        **report,
        **({} if check is None else {"slip_law_check": check}),
    }


def other_law_fits(datasets, law: str, seed: int) -> list:
    """``(fitted, trust block)`` per dataset (with a slip sd) under slip law ``law``: the LM fit of
    the dataset with that law's nodes (:func:`.fit_program.slip_nodes`), padded to its length
    bucket (:func:`.batch_fit.fit_datasets`, key ``seed``), and its :func:`trust_report`, all
    through the kept programs; ``fit`` and ``posterior`` check their law against this one."""
    others = [slip_nodes(d, law) for d in datasets]
    fitted = fit_datasets(others, "lm", seed_key(seed), fit=fit_polach)
    return [(f, trust_report(d, f.fit)) for d, f in zip(others, fitted, strict=True)]


def _slip_law_checks(args, datasets) -> list:
    """Per dataset, the LM fit under the other slip law (:func:`.likelihood.other_slip_law`) and
    its trust block (``law``, ``method``, ``params``, ``mae``, ``status``, ``converged``,
    ``seconds``, ``uncertainty``, ``derived``), or ``None``: for raw creep and creepage files (no
    slip sd) and with ``--single-law``."""
    todo = [i for i, d in enumerate(datasets) if d.slip_sd is not None and not args.single_law]
    checks = [None] * len(datasets)
    if not todo:
        return checks
    law = other_slip_law(args.slip_law)
    others = other_law_fits([datasets[i] for i in todo], law, args.seed)
    for i, (f, report) in zip(todo, others, strict=True):
        status = status_of(f.fit.status)
        checks[i] = {
            "law": law,
            "method": "lm",
            "params": _params(f.fit),
            "mae": float(f.fit.mae),
            "status": status.label,
            "converged": status.converged,
            "seconds": f.seconds,
            "uncertainty": report["uncertainty"],
            "derived": report["derived"],
        }
    return checks


def _fit_all(args, datasets) -> list[dict]:
    """Every dataset fitted padded to its length bucket (:func:`.batch_fit.fit_datasets`: one
    compiled program per method and bucket, Polach's kept); Polach's also under the other slip law
    (:func:`_slip_law_checks`)."""
    fitted = fit_datasets(
        datasets,
        args.method,
        seed_key(args.seed),
        **_budget(args),
        fit=fit_kiencke if args.model == "kiencke" else fit_polach,
    )
    if args.model == "kiencke":
        return [{"method": args.method, **fit_document(f.fit), "seconds": f.seconds} for f in fitted]
    checks = _slip_law_checks(args, datasets)
    return [
        _polach_doc(args, d, f.fit, f.seconds, c) for d, f, c in zip(datasets, fitted, checks, strict=True)
    ]


def _plot(args, path, dataset, doc, many: bool) -> None:
    # On purpose here, not at the top: matplotlib costs a fit process 0.4 s, and only --plot uses it.
    from ..plots.fit import fit_figure

    out = Path(args.plot)
    out.mkdir(parents=True, exist_ok=True)
    theta = np.array([doc["params"][n] for n in PARAM_NAMES])
    peak = doc.get("derived")  # Polach fits only
    figure = out / (f"{path.stem}.fit.png" if many else "fit.png")
    fit_figure(
        dataset, theta, title=f"{path.name}: {args.method}", peak=peak, speed=doc.get("vehicle_speed")
    ).savefig(figure, dpi=110)
    doc["plots"] = [str(figure)]  # as online's: what was written


# ---- output -----------------------------------------------------------------------------------


def table_rows(paths, docs) -> list[dict]:
    """``--out``'s rows: file, method, the parameters, mae, status, converged and (Polach) one
    ``stderr_<param>`` per parameter (empty: on a bound or not determined), the reference
    ``vehicle_speed`` and the peak, ``mu_max`` and ``creep_opt`` with their ``stderr_`` (empty:
    no interval)."""
    rows = []
    for path, doc in zip(paths, docs, strict=True):
        row = {
            "file": str(path),
            "method": doc["method"],
            **doc["params"],
            "mae": doc["mae"],
            "status": doc["status"],
            "converged": doc["converged"],
        }
        for name, u in doc.get("uncertainty", {}).items():
            row[f"stderr_{name}"] = "" if u["stderr"] is None else u["stderr"]
        if "derived" in doc:
            row["vehicle_speed"] = doc["vehicle_speed"]
            for name, d in doc["derived"].items():
                row[name] = d["value"]
                row[f"stderr_{name}"] = "" if d["stderr"] is None else d["stderr"]
        rows.append(row)
    return rows


def write_table(path, rows) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows({k: repr(v) if isinstance(v, float) else v for k, v in r.items()} for r in rows)
    atomic_write(Path(path), lambda tmp: tmp.write_text(buf.getvalue(), encoding="utf-8"))


def _shown(value) -> str:
    """A number of the text output in 5 significant digits; ``none`` for a missing one."""
    return "none" if value is None else f"{value:.5g}"


def _print_one(args, doc) -> None:
    if args.model == "kiencke":
        p = doc["params"]
        print(
            f"Kiencke by {args.method}: p1 {p['p1']:.5g}, p2 {p['p2']:.5g}, a_s {p['a_s']:.5g}; "
            f"mu_max {_shown(doc['mu_max'])}, creep_opt {_shown(doc['creep_opt'])}; MAE {doc['mae']:.5g}; "
            f"{'converged' if doc['converged'] else 'NOT CONVERGED: ' + doc['status']}"
        )
        for w in doc["warnings"]:
            print(f"warning [{w['code']}]: {w['message']}")
    else:
        print(
            f"method {doc['method']}: MAE {doc['mae']:.5g}, {doc['iterations']} iterations, "
            f"{doc['evaluations']} evaluations, {doc['seconds']:.2f} s (compilation included)"
        )
        print(_describe(doc))


def _print_many(args, paths, docs) -> None:
    rows = [
        {
            "file": p.name,
            **{k: (f"{v:.5g}" if isinstance(v, float) else v) for k, v in d["params"].items()},
            "MAE": f"{d['mae']:.5g}",
            **({"mu_max": f"{d['derived']['mu_max']['value']:.4g}"} if "derived" in d else {}),
            "status": d["status"],
            "warnings": ",".join(sorted({w["code"] for w in d.get("warnings", [])})) or "-",
        }
        for p, d in zip(paths, docs, strict=True)
    ]
    print(
        f"{len(docs)} files, {args.model} by {args.method}, "
        f"{sum(d['seconds'] for d in docs):.2f} s fitting (compilation included)"
    )
    print(table(rows, list(rows[0])))


def _load_all(args, paths) -> tuple[list, list, list]:
    """``(paths, loaded, skipped)``: :func:`_load` of each file. Without ``--keep-going`` the first
    file that cannot be used stops the call (its one-line error); with it, each such file is
    reported on stderr and in ``skipped`` [{``file``, ``error``}], and the call stops only when
    none can be used (a single file: its own one line, as without the flag)."""
    kept, loaded, skipped = [], [], []
    for path in paths:
        try:
            loaded.append(_load(args, path))
        except UserError as error:
            if not args.keep_going or len(paths) == 1:  # one file: its one line, nothing to go on to
                raise
            skipped.append({"file": str(path), "error": str(error)})
            sys.stderr.write(f"jadhesion: skipped: {error}\n")
            continue
        kept.append(path)
    if not loaded:
        raise UserError(f"fit: none of the {len(paths)} files can be used (each is listed above)")
    return kept, loaded, skipped


def run(args) -> int:
    """Fit one or many recordings and print (or ``--json``, ``--out``) the results with their
    trust blocks."""
    _check_flags(args)
    paths, many = expand_files(args.file)
    _check_out_is_no_input(args, paths)
    _check_figure_names(args, paths, many)
    paths, loaded, skipped = _load_all(args, paths)  # every file checked before any fit
    datasets = [d for d, _, _ in loaded]
    _check_population(args, paths, datasets)
    docs = _fit_all(args, datasets)
    for doc, (dataset, selection, report) in zip(docs, loaded, strict=True):
        doc["creep"] = args.creep if report["raw_signals"] else "given"  # a creepage column as it is
        doc["slip_law"] = slip_law_used(args, dataset, args.model == "polach")
        doc["slip_sd_scale"] = sd_scale_summary(dataset)
        doc["selection"] = selection.document()
        doc["vehicle"] = report["vehicle"]
        doc["warnings"] = report["warnings"] + doc.get("warnings", [])  # the recording's first
        doc["notes"] = report["notes"]
    if args.plot is not None and args.model == "polach":
        for path, dataset, doc in zip(paths, datasets, docs, strict=True):
            _plot(args, path, dataset, doc, many)
    if args.out is not None:
        write_table(args.out, table_rows(paths, docs))
    if args.json:
        fits = [{"file": str(p), **d} for p, d in zip(paths, docs, strict=True)]
        emit_json({"fits": fits, **({"skipped": skipped} if args.keep_going else {})} if many else fits[0])
    elif many:
        _print_many(args, paths, docs)
        if skipped:
            print(f"{len(skipped)} file(s) skipped, each with its reason on stderr")
    else:
        print(loaded[0][1].summary())
        _print_one(args, docs[0])
    if not args.json:
        say_written([p for d in docs for p in d.get("plots", [])] + ([] if args.out is None else [args.out]))
    return 0
