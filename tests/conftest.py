"""Strict test settings: float64, no silent rank promotion, fixed keys (see STYLE.md §7).

The tests need nothing outside the repository (reference data is vendored in ``validation/data``) and
write nothing to the user's home: the CLI's compilation cache goes to a temporary folder.
"""

import os
import tempfile

import jax

os.environ.setdefault("JADHESION_CACHE", tempfile.mkdtemp(prefix="jadhesion-test-cache-"))
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
