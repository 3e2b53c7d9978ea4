"""Presentation helpers shared by the library's reports and the command line (no JAX, no NumPy)."""

from .text import table

__all__ = ["table"]
