"""Neighbour search and compiled kernels (numba): the voxel grid, the per-neighbour and per-point loops, bounding boxes."""
