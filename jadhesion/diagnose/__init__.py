"""Missing-physics diagnosis: locate where the Polach fit and a recording disagree, name the effect
from the catalogue (DESIGN §3), model it, and show the held-out fit improve.

Modules: :mod:`.signals` (the recording split at the observer), :mod:`.extensions` (the extended
models), :mod:`.fitting` (vmapped LM + blocked CV), :mod:`.features` (residual analysis, starts,
sparse discrepancy), :mod:`.select` (statistics, decision), :mod:`.null` (the per-recording
null: clean re-synthesised replicas, max-T p-values), :mod:`.sensitivity` (the
smallest magnitude of each effect a recording could show), :mod:`.diagnosis` (the pipeline),
:mod:`.explain`, :mod:`.report`. What the code knows about each effect is the effect registry
(:data:`jadhesion.models.effects.EFFECTS`).
"""

from .diagnosis import diagnose
from .extensions import NAMES as EFFECT_NAMES

__all__ = ["diagnose", "EFFECT_NAMES"]
