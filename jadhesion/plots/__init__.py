"""Figures. Each module draws one kind of figure with matplotlib's Agg backend and returns the
:class:`matplotlib.figure.Figure`; callers save it."""
