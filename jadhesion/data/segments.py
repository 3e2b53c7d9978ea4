"""Segments of a recording: the time window ``--start/--end`` [s] (:func:`trim`) and the automatic
selection of the samples the observer can use (:func:`select`). NumPy only.

**Stretches (gaps).** A time step longer than ``max(GAP_FACTOR × median step, GAP_MIN_S)`` (5× the
median step and at least 0.5 s) is a gap: it splits the recording into stretches, and the observer
and the creep smoother run on each stretch alone (never across a gap). A stretch between gaps with fewer than
:data:`MIN_STRETCH_SAMPLES` samples is too short for the smoother and is excluded (a recording
too short as a whole is left to the identification's own minimum, which names it).

**Samples used.** Each sample of a stretch gets one reason, the first that applies:

* ``standstill``: ``|vehicle_speed| < MIN_SPEED`` (0.2 m/s = 0.72 km/h; below it creep
  ``w / |v|`` is dominated by speed-sensor noise and quantisation);
* ``direction change``: moving, but the wheel turns against the direction of travel, or within
  :data:`DIRECTION_GUARD_S` of a reversal of ``vehicle_speed``;
* ``coasting``: the drive — torque in the direction of travel, ``sign(v) · T`` (or ``sign(v) · μ``
  for a file without torque) — below ``MIN_DRIVE_MU`` (0.02) of the axle's weight × wheel radius;
* ``torque and creep disagree``: the creep in the direction of travel has the opposite sign of the
  drive by more than :data:`CREEP_TOLERANCE` (0.005);
* otherwise the sample is ``traction`` (positive drive) or ``braking`` (negative drive and creep);
  the phase not asked for by ``--phase`` is excluded under its own name, and counted.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import RecordingError

#: Gap: a time step above ``max(GAP_FACTOR × median step, GAP_MIN_S)`` splits the recording.
GAP_FACTOR = 5.0
GAP_MIN_S = 0.5
#: Fewest samples of a stretch the observer and the creep smoother run on.
MIN_STRETCH_SAMPLES = 20
#: Standstill below this |vehicle speed| [m/s].
MIN_SPEED = 0.2
#: Coasting below this drive, as a fraction of the axle weight × wheel radius (an adhesion [-]).
MIN_DRIVE_MU = 0.02
#: Creep [-] of the opposite sign to the drive tolerated (sensor noise at small creep).
CREEP_TOLERANCE = 0.005
#: Samples this close [s] to a reversal of the vehicle speed are excluded.
DIRECTION_GUARD_S = 1.0
PHASES = ("traction", "braking", "both")
#: Exclusion reasons, in the order they are tested.
REASONS = (
    "short stretch",
    "standstill",
    "direction change",
    "coasting",
    "torque and creep disagree",
    "braking",
    "traction",
)
#: Most excluded stretches listed in a report (the counts by reason are always complete).
MAX_LISTED = 200


def trim(recording, start=None, end=None):
    """The samples with ``start <= time <= end`` [s] (either bound optional), as a new Recording.

    Raises:
        RecordingError: a bound that is not finite, ``start >= end``, no ``time`` column, or no
            sample in the window; the line names the file and the flag.
    """
    if start is None and end is None:
        return recording
    name = str(recording.path)
    for flag, value in (("--start", start), ("--end", end)):
        if value is not None and not np.isfinite(value):
            raise RecordingError(f"{name}: {flag} {value}: expected a finite time in seconds")
    if start is not None and end is not None and start >= end:
        raise RecordingError(f"{name}: --start {start:g} s is not before --end {end:g} s")
    if "time" not in recording.columns:
        raise RecordingError(
            f"{name}: --start/--end need a time column (map one with --column time=SOURCE[s])"
        )
    t = recording.columns["time"]
    keep = np.ones(t.shape, bool)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    if keep.sum() < 2:
        raise RecordingError(
            f"{name}: --start/--end select {int(keep.sum())} sample(s); the "
            f"recording runs from {t[0]:.15g} s to {t[-1]:.15g} s (the bounds are times as "
            "recorded, not seconds from its start)"
        )
    return slice_recording(recording, keep)


def slice_recording(recording, index):
    """The recording with every column indexed by ``index`` (a slice or a boolean mask)."""
    return dataclasses.replace(recording, columns={k: v[index] for k, v in recording.columns.items()})


@dataclasses.dataclass(frozen=True)
class Selection:
    """The samples of a recording an identification uses.

    Attributes:
        mask: bool (n,), the samples used.
        stretches: ``(i0, i1)`` index ranges between gaps (``i1`` exclusive), all of them.
        labels: str (n,), per sample ``"traction"``, ``"braking"`` or the reason it is excluded.
        phase: ``"traction"``, ``"braking"`` or ``"both"``.
        time: the sample times [s] (sample index when the file has no ``time``).
        gaps: ``(t0, t1)`` of each gap [s].
    """

    mask: np.ndarray
    stretches: tuple
    labels: np.ndarray
    phase: str
    time: np.ndarray
    gaps: tuple = ()

    @property
    def used(self) -> int:
        return int(self.mask.sum())

    @property
    def complete(self) -> bool:
        """Every sample used, in one stretch (a contiguous series)."""
        return bool(self.mask.all()) and len(self.stretches) == 1

    def excluded(self) -> list:
        """Excluded runs ``{reason, start, end, samples}`` (times [s]) in time order; a run never
        crosses a gap."""
        runs = []
        for i0, i1 in self.stretches:
            lab, keep = self.labels[i0:i1], self.mask[i0:i1]
            edges = np.flatnonzero((lab[1:] != lab[:-1]) | (keep[1:] != keep[:-1])) + 1
            for a, b in zip(np.r_[0, edges], np.r_[edges, i1 - i0], strict=True):
                if not keep[a]:
                    runs.append(
                        {
                            "reason": str(lab[a]),
                            "start": float(self.time[i0 + a]),
                            "end": float(self.time[i0 + b - 1]),
                            "samples": int(b - a),
                        }
                    )
        return runs

    def where_broken(self, most: int = 3) -> str:
        """Where the series breaks: its first ``most`` excluded runs (``reason at t = t0–t1 s (k
        samples)``) and gaps (``gap at t = t0–t1 s``), with how many more there are; ``""`` for a
        contiguous series."""
        runs = self.excluded()
        out = [
            f"{r['reason']} at t = {r['start']:.6g}"
            + (f"–{r['end']:.6g} s ({r['samples']} samples)" if r["samples"] > 1 else " s")
            for r in runs[:most]
        ] + [f"gap at t = {a:.6g}–{b:.6g} s" for a, b in self.gaps[:most]]
        more = max(len(runs) - most, 0) + max(len(self.gaps) - most, 0)
        return ", ".join(out) + (f" and {more} more" if more else "")

    def counts(self) -> dict:
        """Samples per label (used phases and exclusion reasons)."""
        names, counts = np.unique(self.labels, return_counts=True)
        return {str(k): int(c) for k, c in zip(names, counts, strict=True)}

    def summary(self) -> str:
        """One line: samples used of all, the phase, and the excluded counts by reason."""
        counts = self.counts()
        wanted = ("traction", "braking") if self.phase == "both" else (self.phase,)
        out = [f"{k} {v}" for k, v in sorted(counts.items()) if k not in wanted]
        gaps = f", {len(self.stretches)} stretches between {len(self.gaps)} gap(s)" if self.gaps else ""
        return (
            f"samples: {self.used} of {self.mask.size} used ({self.phase}{gaps}); excluded: "
            f"{', '.join(out) if out else 'none'}"
        )

    def document(self) -> dict:
        """The selection as JSON: ``phase``, ``used``, ``samples``, ``stretches`` [[t0, t1]],
        ``gaps`` [[t0, t1]], ``counts`` by label, ``excluded`` runs (at most :data:`MAX_LISTED`;
        ``excluded_listed_all`` says whether all are)."""
        runs = self.excluded()
        return {
            "phase": self.phase,
            "used": self.used,
            "samples": int(self.mask.size),
            "stretches": [[float(self.time[a]), float(self.time[b - 1])] for a, b in self.stretches],
            "gaps": [list(g) for g in self.gaps],
            "counts": self.counts(),
            "excluded": runs[:MAX_LISTED],
            "excluded_listed_all": len(runs) <= MAX_LISTED,
        }


def longest_run(flags) -> tuple[int, int] | None:
    """``(start, stop)`` (``stop`` exclusive) of the longest run of consecutive true ``flags``
    (bool (n,)), the first of equal ones; ``None`` when none is true."""
    edges = np.diff(np.concatenate([[0], np.asarray(flags, bool).astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if not starts.size:
        return None
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k])


def gap_limit(dt) -> float:
    """The longest time step [s] that is not a gap, of the steps ``dt`` [s] (at least one):
    ``max(GAP_FACTOR × median step, GAP_MIN_S)``."""
    return max(GAP_FACTOR * float(np.median(dt)), GAP_MIN_S)


def find_stretches(time):
    """``(stretches, gaps)``: index ranges between gaps (:func:`gap_limit`) and the gaps'
    ``(t0, t1)`` [s]."""
    n = len(time)
    if n < 2:
        return ((0, n),), ()
    dt = np.diff(time)
    cuts = np.flatnonzero(dt > gap_limit(dt)) + 1
    bounds = np.r_[0, cuts, n]
    gaps = tuple((float(time[i - 1]), float(time[i])) for i in cuts)
    return tuple((int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)), gaps


def raw_creep(cols, v):
    """Creep [-] of each sample as recorded: ``creepage``, or the slip velocity (``slip_velocity``,
    else ``wheel_speed − vehicle_speed``) over ``max(|v|, MIN_SPEED)``; zeros without either."""
    if "creepage" in cols:
        return np.asarray(cols["creepage"])
    if "slip_velocity" in cols:
        w = np.asarray(cols["slip_velocity"])
    elif "wheel_speed" in cols:
        w = np.asarray(cols["wheel_speed"]) - v
    else:
        return np.zeros_like(v)
    return w / np.maximum(np.abs(v), MIN_SPEED)


def _near_reversal(t, v, moving, stretches):
    near = np.zeros(t.shape, bool)
    for a, b in stretches:
        direction = np.sign(v[a:b])
        idx = np.flatnonzero(moving[a:b])
        flips = idx[1:][direction[idx[1:]] != direction[idx[:-1]]]
        for k in flips:  # the reversal lies between the previous moving sample and this one
            prev = idx[np.searchsorted(idx, k) - 1]
            t0, t1 = t[a + prev] - DIRECTION_GUARD_S, t[a + k] + DIRECTION_GUARD_S
            near[a:b] |= (t[a:b] >= t0) & (t[a:b] <= t1)
    return near


def select(recording, phase: str = "traction") -> Selection:
    """The :class:`Selection` of ``recording``'s samples for ``phase`` (module docstring: the
    rules, limits and reasons). Raises :class:`RecordingError` for an unknown phase."""
    if phase not in PHASES:
        raise RecordingError(f"{recording.path}: --phase {phase}: expected one of {', '.join(PHASES)}")
    cols = recording.columns
    v = np.asarray(cols["vehicle_speed"], dtype=np.float64)
    n = v.size
    t = np.asarray(cols["time"], dtype=np.float64) if "time" in cols else np.arange(n, dtype=float)
    stretches, gaps = find_stretches(t) if "time" in cols else (((0, n),), ())
    direction = np.where(v < 0, -1.0, 1.0)
    if "traction_torque" in cols:
        veh = recording.vehicle
        drive = direction * cols["traction_torque"] / (veh.axle_weight_n * veh.wheel_radius_m)
    elif "adhesion" in cols:
        drive = direction * cols["adhesion"]
    else:
        drive = np.ones(n)
    creep = direction * raw_creep(cols, v)
    moving = np.abs(v) >= MIN_SPEED
    against = np.zeros(n, bool)
    if "wheel_speed" in cols:
        against = np.sign(cols["wheel_speed"]) == -direction
    labels = np.where(drive > 0, "traction", "braking").astype(object)
    tests = [
        ("torque and creep disagree", creep * np.sign(drive) < -CREEP_TOLERANCE),
        ("coasting", np.abs(drive) < MIN_DRIVE_MU),
        ("direction change", moving & (against | _near_reversal(t, v, moving, stretches))),
        ("standstill", ~moving),
    ]
    for reason, hit in tests:  # later tests take precedence
        labels[hit] = reason
    short = np.zeros(n, bool)
    for a, b in stretches if len(stretches) > 1 else ():  # one short recording: too few samples
        short[a:b] = b - a < MIN_STRETCH_SAMPLES
    labels[short] = "short stretch"
    wanted = ("traction", "braking") if phase == "both" else (phase,)
    mask = np.isin(labels, wanted)
    return Selection(
        mask=mask, stretches=stretches, labels=labels.astype(str), phase=phase, time=t, gaps=gaps
    )
