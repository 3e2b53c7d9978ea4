"""Load the recording a command names, with the shared options of :mod:`.recording_options`."""

from __future__ import annotations

from ..data.dataset import to_dataset
from ..data.recording import Recording, load_recording
from ..data.segments import trim
from ..data.selected import selected_dataset


def load_from_args(args, path) -> Recording:
    """The :class:`~jadhesion.data.recording.Recording` at ``path`` with ``--column``, ``--axle``,
    ``--start`` and ``--end`` from ``args`` applied."""
    return trim(load_recording(path, columns=args.column, axle=args.axle), args.start, args.end)


def load_dataset(args, path, build=to_dataset):
    """``(recording, dataset, selection)``: :func:`load_from_args`, then the dataset of the samples
    of ``--phase`` (:func:`jadhesion.data.selected.selected_dataset`, observer and smoother per
    stretch between gaps; ``--creep`` when the command has it). ``build`` makes one stretch's
    dataset (default :func:`jadhesion.data.dataset.to_dataset`)."""
    recording = load_from_args(args, path)
    dataset, selection = selected_dataset(recording, args.phase,
                                          creep=getattr(args, "creep", "smoothed"), build=build)
    return recording, dataset, selection
