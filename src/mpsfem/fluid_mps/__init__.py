"""MPS (Moving Particle Semi-implicit) fluid solver: particles in flat arrays, numba kernels."""
