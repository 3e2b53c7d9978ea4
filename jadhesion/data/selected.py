"""The fitting dataset of the samples :func:`jadhesion.data.segments.select` keeps.

The observer and the creep smoother run on each stretch between gaps alone (a time series filter
must never bridge a gap); only then is the selection mask applied, so every selected sample has
its full observer history within its stretch. With every sample selected in one stretch the
result is exactly :func:`jadhesion.data.dataset.to_dataset` of the recording.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..errors import RecordingError
from .dataset import PolachDataset, to_dataset
from .segments import MIN_STRETCH_SAMPLES, Selection, select, slice_recording


def _concatenate(parts) -> PolachDataset:
    first = parts[0]
    fields = {}
    for name in PolachDataset._fields:
        if name == "k_eps":
            fields[name] = first.k_eps
        elif getattr(first, name) is None:
            fields[name] = None
        else:
            fields[name] = jnp.concatenate([getattr(p, name) for p in parts])
    return PolachDataset(**fields)


def no_samples_message(recording, selection: Selection) -> str:
    """One line: the phase selected nothing, and what the samples were."""
    counts = ", ".join(f"{k} {v}" for k, v in sorted(selection.counts().items()))
    return (
        f"{recording.path}: --phase {selection.phase} selects no samples ({counts}); try "
        f"another --phase or --start/--end"
    )


def per_stretch_dataset(
    recording, selection: Selection, observer_variant: str = "paper", creep: str = "raw", *, build=to_dataset
) -> PolachDataset:
    """The dataset of every sample (none masked), the observer run on each stretch alone (default
    ``creep="raw"``: any stretch length); for inspection and figures."""
    parts = [
        build(slice_recording(recording, slice(a, b)), observer_variant, creep)
        for a, b in selection.stretches
    ]
    return parts[0] if len(parts) == 1 else _concatenate(parts)


def selected_dataset(
    recording,
    phase: str = "traction",
    observer_variant: str = "paper",
    creep: str = "smoothed",
    *,
    build=to_dataset,
):
    """``(PolachDataset, Selection)``: the dataset of the samples of ``phase``.

    ``build(recording, observer_variant, creep)`` makes one stretch's dataset (default
    :func:`~jadhesion.data.dataset.to_dataset`; the CLI passes its cached drop-in).

    Raises:
        RecordingError: no sample selected (the line gives the counts by reason).
    """
    selection = select(recording, phase)
    if selection.used == 0:
        raise RecordingError(no_samples_message(recording, selection))
    if selection.mask.size < MIN_STRETCH_SAMPLES:  # too short for the smoother: the raw
        creep = "raw"  # difference (the fit names its minimum)
    if selection.complete:
        return build(recording, observer_variant, creep), selection
    parts = []
    for a, b in selection.stretches:
        keep = selection.mask[a:b]
        if not keep.any():
            continue
        data = build(slice_recording(recording, slice(a, b)), observer_variant, creep)
        parts.append(
            type(data)(
                *(
                    f if f is None or name == "k_eps" else f[keep]
                    for name, f in zip(PolachDataset._fields, data, strict=True)
                )
            )
        )
    return _concatenate(parts), selection
