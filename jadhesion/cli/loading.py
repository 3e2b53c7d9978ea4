"""Load the recording a command names, with the shared options of :mod:`.recording_options`."""

from __future__ import annotations

import dataclasses
import sys

from ..data.dataset import adhesion_source, to_dataset
from ..data.recording import Recording, load_recording
from ..data.segments import trim
from ..data.selected import selected_dataset
from ..data.sidecar import sidecar_warning, unknown_key_notes
from ..errors import VehicleError


def load_from_args(args, path) -> Recording:
    """The :class:`~jadhesion.data.recording.Recording` at ``path`` with ``--column``, ``--axle``,
    ``--missing``, ``--repeated-time``, ``--start`` and ``--end`` from ``args`` applied (with a note when its
    ``adhesion`` column is ignored, :func:`jadhesion.data.dataset.adhesion_source`)."""
    recording = load_recording(
        path,
        columns=args.column,
        axle=args.axle,
        missing=args.missing,
        repeated_time=args.repeated_time,
    )
    if recording.has_adhesion and adhesion_source(recording) == "observer":
        note = (
            f"{recording.path}: column 'adhesion' ignored: mu_hat is the observer's output of the raw signals"
        )
        recording = dataclasses.replace(recording, notes=recording.notes + (note,))
    return trim(recording, args.start, args.end)


def say_notes(recording: Recording) -> None:
    """The reader's notes on ``recording`` (time stamps that look like ms, decimal commas, rows
    skipped or dropped, a column ignored), said on stderr as soon as it is loaded, each as
    ``jadhesion: note: …`` (``fit``'s and ``diagnose``'s JSON carry them as ``notes``)."""
    for note in recording.notes:
        sys.stderr.write(f"jadhesion: note: {note}\n")


def say_notes_and_sidecar_warning(recording: Recording) -> dict | None:
    """:func:`say_notes`, but the sidecar's unknown keys said once, as the recording's
    ``sidecar_unknown_key`` warning (:func:`jadhesion.data.sidecar.sidecar_warning`, returned;
    ``None`` when its sidecar has no unknown key), before anything it may explain."""
    warning = sidecar_warning(recording)
    said = unknown_key_notes(recording)
    for note in recording.notes:
        if note not in said:
            sys.stderr.write(f"jadhesion: note: {note}\n")
    if warning is not None:
        sys.stderr.write(f"jadhesion: warning: {warning['message']}\n")
    return warning


def load_dataset(args, path, build=to_dataset, *, recording: Recording | None = None):
    """``(recording, dataset, selection)``: :func:`load_from_args`, then the dataset of the samples
    of ``--phase`` (:func:`jadhesion.data.selected.selected_dataset`, observer and smoother per
    stretch between gaps; ``--creep`` when the command has it). ``build`` makes one stretch's
    dataset (default :func:`jadhesion.data.dataset.to_dataset`); ``recording``: the one
    :func:`load_from_args` already gave, when the caller has it."""
    if recording is None:
        recording = load_from_args(args, path)
    try:
        dataset, selection = selected_dataset(
            recording, args.phase, creep=getattr(args, "creep", "smoothed"), build=build
        )
    except VehicleError as error:  # several files: say which sidecar
        raise VehicleError(f"{recording.path.with_suffix('.json')}: {error}") from None
    return recording, dataset, selection


def slip_law_used(args, dataset, applies: bool = True) -> str | None:
    """The JSON's ``slip_law``: ``--slip-law``, or ``None`` where the fit has no slip law (raw
    creep, a creepage file, a model without the errors-in-variables curve: ``applies`` false); a
    population law asked for there is said on stderr, not silently dropped."""
    law = getattr(args, "slip_law", "normal")
    if applies and dataset.slip_sd is not None:
        return law
    if law != "normal":
        why = "the creep has no uncertainty (raw, or a creepage column) or the model no slip law"
        sys.stderr.write(f"jadhesion: warning: --slip-law {law} has no effect here: {why}\n")
    return None
