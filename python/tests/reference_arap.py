"""libigl's spokes-and-rims ARAP iteration in numpy, in double precision throughout.

libigl 2.6's ``arap_solve`` fits its rotations with ``fit_rotations(S, true, R)``: the
*single-precision* 3x3 polar SVD (hence the normalization of S before it, "important to get
single precision SVD code to work correctly"), whose rotations are off by ~1e-5. Its fixed
point therefore differs from the double-precision one, and has a higher energy. This module
runs the same iteration (libigl's cotangent entries, covariances over the triangles around a
vertex, the global step with the triangle-mean rotation) with either numpy's double SVD or
libigl's own single-precision fit, to tell that rounding apart from a difference of method.
"""
import numpy as np


def closest_rotations(S):
    """argmax_R tr(R S) per 3x3 cell (R = V U^T of S = U Sigma V^T, reflections fixed)."""
    u, _, vt = np.linalg.svd(S)
    R = np.einsum("nji,nkj->nik", vt, u)
    bad = np.linalg.det(R) < 0
    if bad.any():
        u[bad, :, 2] *= -1
        R[bad] = np.einsum("nji,nkj->nik", vt[bad], u[bad])
    return R


def arap_double(igl, V, F, b, bc, U0, iterations, libigl_rotations=False):
    """``iterations`` local-global steps of spokes-and-rims ARAP from ``U0``; returns U.

    Needs scipy (installed with libigl).

    ``libigl_rotations``: fit the rotations as libigl's arap_solve does,
    ``igl.fit_rotations(S / max|S|, single_precision=True)`` (errors ~1e-5), instead of numpy's
    double-precision SVD: this reproduces libigl's own pose."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = len(V)
    c = igl.cotmatrix_entries(V, F)  # #F x 3: half cotangent of the edge opposite corner k
    i1, i2 = F[:, [1, 2, 0]], F[:, [2, 0, 1]]  # edge k = (i1, i2)
    e = V[i1] - V[i2]  # #F x 3 x 3 rest edges
    nf = len(F)
    inc = sp.csr_matrix((np.ones(3 * nf), (F.reshape(-1), np.repeat(np.arange(nf), 3))), shape=(n, nf))
    # Global matrix: every edge appears in the three cells of its triangle.
    w = 3 * c
    rows = np.concatenate([i1.ravel(), i2.ravel(), i1.ravel(), i2.ravel()])
    cols = np.concatenate([i2.ravel(), i1.ravel(), i1.ravel(), i2.ravel()])
    vals = np.concatenate([-w.ravel(), -w.ravel(), w.ravel(), w.ravel()])
    L = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    free = np.setdiff1d(np.arange(n), b)
    solve = spla.factorized(L[free][:, free].tocsc())
    L_fb = L[free][:, b]
    # Edge k of triangle f -> +1 at i1, -1 at i2 (sums the per-edge terms into the rhs).
    m = 3 * nf
    D = sp.csr_matrix((np.concatenate([np.ones(m), -np.ones(m)]),
                       (np.concatenate([i1.ravel(), i2.ravel()]), np.tile(np.arange(m), 2))), shape=(n, m))
    U = U0.copy()
    U[b] = bc
    for _ in range(iterations):
        d = U[i1] - U[i2]
        cov = np.einsum("fk,fki,fkj->fij", c, e, d).reshape(-1, 9)
        S = (inc @ cov).reshape(-1, 3, 3)
        if libigl_rotations:
            stack = S.transpose(1, 0, 2).reshape(3 * n, 3)  # row i*n + r: row i of S_r
            R = igl.fit_rotations(stack / np.abs(stack).max(), True)
            R = R.reshape(3, n, 3).transpose(1, 0, 2)  # block r of a 3 x 3n matrix
        else:
            R = closest_rotations(S)
        Rbar = (R[F[:, 0]] + R[F[:, 1]] + R[F[:, 2]]) / 3
        re = w[:, :, None] * np.einsum("fij,fkj->fki", Rbar, e)  # w R e per edge
        rhs = D @ re.reshape(-1, 3)
        r = rhs[free] - L_fb @ bc
        U[free] = np.column_stack([solve(r[:, k]) for k in range(3)])
    return U
