"""``jadhesion sweep``'s work: join a multi-process run if asked, run the grid, report (arguments:
:mod:`.sweep`)."""

from __future__ import annotations

import jax

from ..data.simulator import DEFAULT_SAMPLES
from ..identify.methods import METHODS, POPULATION
from ..sweeps import Grid, run_sweep
from ..sweeps.grid import MAX_NOISE_SCALE, MIN_GRID_SAMPLES
from .common import (
    MAX_ITER,
    MAX_POPULATION_BYTES,
    Progress,
    UserError,
    emit_json,
    require_at_least,
    require_in_range,
    require_output_file,
)
from .simulate_run import MAX_SAMPLES
from .sweep import MAX_SEEDS


def _list(kind, flag: str, text: str) -> list:
    """A comma-separated ``--flag`` value as a list of ``kind``; an empty item is refused."""
    items = [t.strip() for t in text.split(",")]
    if "" in items:
        raise UserError(f"sweep: {flag} {text!r}: empty item (expected comma-separated values)")
    try:
        return [kind(t) for t in items]
    except ValueError:
        raise UserError(f"sweep: {flag} {text!r}: cannot read it as {kind.__name__}s") from None


def _initialize(args) -> None:
    explicit = (args.coordinator, args.num_processes, args.process_id)
    if not (args.distributed or any(v is not None for v in explicit)) or jax.distributed.is_initialized():
        return
    if any(v is None for v in explicit) and not args.distributed:
        raise UserError("sweep: --coordinator, --num-processes and --process-id go together")
    try:
        jax.distributed.initialize(*explicit)
    except (RuntimeError, ValueError) as exc:
        raise UserError(f"sweep: cannot join the multi-process run: {exc}") from None


#: Fits per compiled batch when ``--chunk-size`` is not given (fewer where they would not fit).
DEFAULT_CHUNK = 64


def _check_chunk_memory(args, methods) -> None:
    """A chunk's fits run as one batch, padded to ``--chunk-size``: chunk × samples values (× the
    population of a population method) per evaluation within :data:`.common.MAX_POPULATION_BYTES`.
    Without ``--chunk-size``, :data:`DEFAULT_CHUNK` or the largest chunk within it. --chunk-size
    10**9 was killed by the kernel's OOM killer, --samples 10**9 asked XLA for 4 TB."""
    pops = [args.pop_size or METHODS[m].defaults["pop_size"] for m in methods if m in POPULATION]
    pop = max(pops, default=1)
    samples = args.samples or DEFAULT_SAMPLES
    if args.chunk_size is None:
        args.chunk_size = max(1, min(DEFAULT_CHUNK, MAX_POPULATION_BYTES // (8 * samples * pop)))
    need = args.chunk_size * samples * pop * 8
    if need > MAX_POPULATION_BYTES:
        members = f", populations of {pop}," if pop > 1 else ""
        chunk = MAX_POPULATION_BYTES // (8 * samples * pop)
        fix = (
            f"--chunk-size {chunk} or less" + (" or a smaller --pop-size" if pop > 1 else "")
            if chunk >= 1
            else f"--pop-size {MAX_POPULATION_BYTES // (8 * samples)} or less and --chunk-size 1"
        )
        raise UserError(
            f"sweep: --chunk-size {args.chunk_size} fits of {samples} samples{members} need "
            f"{need / 2**30:.3g} GiB per evaluation, more than {MAX_POPULATION_BYTES / 2**30:g} GiB: "
            f"use {fix}"
        )


def run(args) -> int:
    """Run the sweep the arguments describe; print (or ``--json``) its summary on process 0."""
    require_in_range("sweep", 1, MAX_SEEDS, seeds=args.seeds)
    require_at_least("sweep", 1, chunk_size=args.chunk_size)
    require_in_range("sweep", 1, MAX_ITER, max_iter=args.max_iter)
    require_at_least("sweep", 2, pop_size=args.pop_size)
    require_in_range("sweep", MIN_GRID_SAMPLES, MAX_SAMPLES, samples=args.samples)  # the grid's least
    methods = _list(str, "--methods", args.methods)
    noise = _list(float, "--noise", args.noise)
    for scale in noise:  # the grid's own check, said with the flag's name
        require_in_range("sweep", 0.0, MAX_NOISE_SCALE, noise=scale)
    _check_chunk_memory(args, methods)
    require_output_file("sweep", args.out, (".csv", ".parquet"))  # the table writer's formats
    _initialize(args)
    budget = {"pop_size": args.pop_size, "max_iter": args.max_iter}
    grid = Grid(
        scenarios=_list(str, "--scenarios", args.scenarios),
        seeds=range(args.seeds),
        methods=methods,
        noise_scale=noise,
        creep_max=_list(float, "--creep-max", args.creep_max),
        n_samples=args.samples,
        fit_options={k: v for k, v in budget.items() if v is not None},
    )
    with Progress(label="sweep", unit="fits") as progress:
        _, summary = run_sweep(
            grid, args.out, chunk_size=args.chunk_size, resume=args.resume, progress=progress
        )
    if jax.process_index() != 0:
        return 0
    doc = summary._asdict()
    if args.json:
        emit_json(doc)
    else:
        print(
            f"{doc['fits']} fits ({doc['computed']} computed, {doc['chunks_computed']}/{doc['chunks']} "
            f"chunks) in {doc['seconds']:.1f} s = {doc['fits_per_second']:.1f} fits/s on "
            f"{doc['devices']} device(s), {doc['processes']} process(es) -> {doc['out']}"
        )
    return 0
