"""Validation kit: reference problems, calibration studies and independent data generators.

Used by the tests and the benchmarks, never by the library (``jadhesion`` does not import it). It is
not installed with the package: run tests and benchmarks from the repository root.
"""
