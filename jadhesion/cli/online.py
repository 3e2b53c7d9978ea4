"""``jadhesion online FILE``: paper 000's online Kiencke identification on a recording.

Raw signals go through the adhesion observer and the creep smoother, per stretch between gaps
(:func:`jadhesion.data.selected.tracking_dataset`); a fitting dataset with ``adhesion`` is used as
it is. The recording options (``--column``, ``--axle``, ``--start/--end``, ``--phase``) are the
other commands'; braking (``--phase braking``) and running backwards are tracked as traction.
Kiencke's ``p1, p2`` and the optimum (``creep_opt`` = λ_m, ``mu_max`` = μ_m) are tracked sample by
sample with the forgetting factor η (:func:`jadhesion.identify.online.track_dataset`, the code path
of ``reproduce online``), whose memory is counted in seconds by default (``--forgetting``: the
paper's per-sample η taken at 50 Hz, :func:`jadhesion.identify.online.step_ratios`). ``a_s`` is
estimated from the data (the initial slope of Kiencke's curve fitted offline by global LM) unless
``--a-s`` is given. Samples outside ``--phase`` (standstill,
coasting, direction changes…) and those the tracker finds uninformative are skipped (the estimate
is held): ``n_used`` counts the samples tracked, ``selection.used`` those of ``--phase``, which
include the uninformative. ``warnings`` reports ``few_samples`` and ``creep_sign`` as ``fit``
does, a ``no_optimum`` (the run ends with ``p2 ≤ 0``: no peak,
:func:`jadhesion.identify.online.optimum_warning`), a ``peak_below_data`` (the final
``mu_max`` well below the adhesion the run showed, with when it last did:
:func:`jadhesion.identify.online.below_data_warning`) and an ``snr_hold``: the SNR step held η at
η_max long enough that the estimate stopped following the data
(:func:`jadhesion.identify.online.hold_warning`);
``--algorithm 1-guarded`` ends a hold when the data stop agreeing with the estimate.

This module defines the arguments only; :mod:`.online_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .recording_options import add_recording_options

#: The identifiers of :data:`jadhesion.identify.online.ALGORITHMS` (a test keeps the two equal).
ALGORITHM_NAMES = ("1", "1-guarded", "2", "rls")
#: :data:`jadhesion.identify.online.FORGETTING` (literal, as ALGORITHM_NAMES).
FORGETTING = ("seconds", "samples")


def register(sub) -> None:
    p = sub.add_parser("online", help=COMMANDS["online"])
    p.add_argument("file", help="recording or creepage CSV")
    p.add_argument(
        "--algorithm",
        choices=ALGORITHM_NAMES,
        default="1",
        help="paper 000's Algorithm 1 (default) or 2; 1-guarded: Algorithm 1 whose SNR step holds "
        "the forgetting factor only while the prediction error is within 3 noise sd, so a larger "
        "change ends a hold; or plain RLS (forgetting 0.98)",
    )
    p.add_argument(
        "--a-s",
        type=float,
        default=None,
        metavar="VALUE",
        help="Kiencke's initial slope a_s [-], 1 to 10000 (default: estimated from the data)",
    )
    p.add_argument(
        "--forgetting",
        choices=FORGETTING,
        default="seconds",
        help="what the forgetting factor's memory is counted in: seconds (default: the paper's "
        "per-sample factors taken at 50 Hz, so the memory in seconds is the same at any logging "
        "rate) or samples (the paper's, whatever the rate); a file without a time column is "
        "tracked per sample",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the a_s estimate's LM (default 0)")
    p.add_argument("--plot", metavar="DIR", default=None, help="write FILE-stem_online.png into DIR")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    add_recording_options(p)
    p.set_defaults(handler="jadhesion.cli.online_run:run")
