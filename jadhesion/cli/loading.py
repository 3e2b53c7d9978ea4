"""Load the recording a command names, with the shared options of :mod:`.recording_options`."""

from __future__ import annotations

import dataclasses

from ..data.dataset import adhesion_source, to_dataset
from ..data.recording import Recording, load_recording
from ..data.segments import trim
from ..data.selected import selected_dataset


def load_from_args(args, path) -> Recording:
    """The :class:`~jadhesion.data.recording.Recording` at ``path`` with ``--column``, ``--axle``,
    ``--start`` and ``--end`` from ``args`` applied (with a note when its ``adhesion`` column is
    ignored, :func:`jadhesion.data.dataset.adhesion_source`)."""
    recording = load_recording(path, columns=args.column, axle=args.axle)
    if recording.has_adhesion and adhesion_source(recording) == "observer":
        note = (
            f"{recording.path}: column 'adhesion' ignored: mu_hat is the observer's output of the raw signals"
        )
        recording = dataclasses.replace(recording, notes=recording.notes + (note,))
    return trim(recording, args.start, args.end)


def load_dataset(args, path, build=to_dataset, *, recording: Recording | None = None):
    """``(recording, dataset, selection)``: :func:`load_from_args`, then the dataset of the samples
    of ``--phase`` (:func:`jadhesion.data.selected.selected_dataset`, observer and smoother per
    stretch between gaps; ``--creep`` when the command has it). ``build`` makes one stretch's
    dataset (default :func:`jadhesion.data.dataset.to_dataset`); ``recording``: the one
    :func:`load_from_args` already gave, when the caller has it."""
    if recording is None:
        recording = load_from_args(args, path)
    dataset, selection = selected_dataset(
        recording, args.phase, creep=getattr(args, "creep", "smoothed"), build=build
    )
    return recording, dataset, selection
