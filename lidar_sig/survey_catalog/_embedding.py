"""A map of the tiles by likeness: classical multidimensional scaling (Torgerson) of a distance
matrix, so that tiles near in the plane have similar signatures."""
from __future__ import annotations

import numpy as np


def classical_mds(distances, dims=2):
    """(N, ``dims``) coordinates whose Euclidean distances best match ``distances`` (N, N,
    symmetric, zero diagonal) in the least-squares sense of the double-centred squared
    distances: the top eigenvectors of B = -1/2 J D^2 J scaled by the square roots of their
    eigenvalues (negative eigenvalues give 0). Signs are fixed so that each axis's largest
    coordinate is positive."""
    d = np.asarray(distances, np.float64)
    n = len(d)
    if n == 0:
        return np.zeros((0, dims))
    centred = d ** 2
    centred = centred - centred.mean(axis=0) - centred.mean(axis=1)[:, None] + centred.mean()
    values, vectors = np.linalg.eigh(-0.5 * centred)
    order = np.argsort(values)[::-1][:dims]
    out = vectors[:, order] * np.sqrt(np.maximum(values[order], 0.0))
    for k in range(out.shape[1]):
        if out[np.argmax(np.abs(out[:, k])), k] < 0:
            out[:, k] = -out[:, k]
    if out.shape[1] < dims:
        out = np.hstack([out, np.zeros((n, dims - out.shape[1]))])
    return out
