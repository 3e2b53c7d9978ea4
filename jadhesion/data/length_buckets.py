"""Length buckets: arrays of many lengths computed by few compiled programs.

XLA compiles one program per array shape, and on CPU every program holds memory maps for the
life of the process (:mod:`jadhesion.memory_maps`). So the observer, the creep smoother and the
fits run on their inputs padded to a *bucket* length (:func:`bucket_length`) with a mask of the
real samples, and every length of a bucket shares one program. The padding's cost is bounded: at
most twice the work up to :data:`FINE_BUCKETS_FROM` samples, less than 1/8 more above.
"""

from __future__ import annotations

#: The bucket of short datasets: :data:`jadhesion.identify.polach_fit.SEED_SAMPLES` (a test keeps
#: them equal).
SHORT_BUCKET = 128
#: The smallest bucket above :data:`SHORT_BUCKET` (buckets then double).
MIN_LONG_BUCKET = 256
#: Above this many samples buckets step by an eighth of an octave instead of doubling: a fit of
#: a long recording costs its length (a 1-hour recording at 100 Hz, 360 000 rows, would waste 31 %
#: of its work padded to 2¹⁹; it wastes 0.2 % padded to 11·2¹⁵), while short ones share few
#: programs (their compilation, not their padding, is what costs).
FINE_BUCKETS_FROM = 16384
#: Buckets per octave above :data:`FINE_BUCKETS_FROM` (padding then < 1/8 of the samples).
STEPS_PER_OCTAVE = 8


def bucket_length(n: int) -> int:
    """The padded length of ``n`` samples: 128 up to 128 samples (LM then seeds on all of them, as
    unpadded); the next power of two ≥ :data:`MIN_LONG_BUCKET` up to :data:`FINE_BUCKETS_FROM`
    (one program for every length in ``(2^(k-1), 2^k]``); above, the next multiple of
    ``2^(k-1) / STEPS_PER_OCTAVE`` (padding less than 1/8 of the samples,
    :data:`STEPS_PER_OCTAVE` programs per octave)."""
    n = int(n)
    if n <= SHORT_BUCKET:
        return SHORT_BUCKET
    octave = 1 << (n - 1).bit_length()
    if n <= FINE_BUCKETS_FROM:
        return max(MIN_LONG_BUCKET, octave)
    step = octave // 2 // STEPS_PER_OCTAVE
    return -(-n // step) * step
