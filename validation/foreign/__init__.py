"""Modules of the independent recording generator (:mod:`validation.foreign_generator`):
``physics`` (vehicles, Hertz/Kalker contact, Polach), ``dynamics`` (wheelset and train, controller,
driving profiles, concealed effects), ``sensors`` (noise, colour, quantisation, timing).

Pure NumPy/SciPy; never imports jadhesion.
"""
