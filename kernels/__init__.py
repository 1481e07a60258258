"""Numba kernels of cosnet (installed as cosnet.kernels)."""
