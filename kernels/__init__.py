"""Numba kernels of vecslice: pure functions over int64 arrays.

Internal: users import :mod:`vecslice`, never this package. Imports go one way only
(vecslice -> kernels -> numpy/numba).
"""
