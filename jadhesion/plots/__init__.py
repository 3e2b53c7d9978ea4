"""Figures. Each module draws one kind of figure on a bare :class:`matplotlib.figure.Figure` (no
pyplot, no global backend) and returns it; callers save it."""
