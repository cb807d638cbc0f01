"""Compiled (numba) QUEST, one sample per loop iteration; see :mod:`sportfusion.estimators.quest`.

Imported lazily by :func:`sportfusion.estimators.quest.quest` for large batches, so that a small
call does not pay numba's import.  Same equations as the numpy path: Davenport's K from the
normalised vectors, ``lambda_max`` in closed form (two vectors) or by Newton-Raphson on the
characteristic polynomial, the eigenvector from the adjugate of ``lambda I - K`` (the column with
the largest diagonal element when Shuster's scalar column is small).
"""

from __future__ import annotations

import math

import numpy as np

from sportfusion.core._numba import preload_cython_blas

preload_cython_blas()  # before numba: its BLAS check then skips importing the scipy.linalg package
from numba import njit  # noqa: E402


@njit(cache=True)
def _adj4_sym(a: np.ndarray, o: np.ndarray) -> None:
    s0 = a[0, 0] * a[1, 1] - a[1, 0] * a[0, 1]
    s1 = a[0, 0] * a[1, 2] - a[1, 0] * a[0, 2]
    s2 = a[0, 0] * a[1, 3] - a[1, 0] * a[0, 3]
    s3 = a[0, 1] * a[1, 2] - a[1, 1] * a[0, 2]
    s4 = a[0, 1] * a[1, 3] - a[1, 1] * a[0, 3]
    s5 = a[0, 2] * a[1, 3] - a[1, 2] * a[0, 3]
    c5 = a[2, 2] * a[3, 3] - a[3, 2] * a[2, 3]
    c4 = a[2, 1] * a[3, 3] - a[3, 1] * a[2, 3]
    c3 = a[2, 1] * a[3, 2] - a[3, 1] * a[2, 2]
    c2 = a[2, 0] * a[3, 3] - a[3, 0] * a[2, 3]
    c1 = a[2, 0] * a[3, 2] - a[3, 0] * a[2, 2]
    o[0, 0] = a[1, 1] * c5 - a[1, 2] * c4 + a[1, 3] * c3
    o[1, 1] = a[0, 0] * c5 - a[0, 2] * c2 + a[0, 3] * c1
    o[2, 2] = a[3, 0] * s4 - a[3, 1] * s2 + a[3, 3] * s0
    o[3, 3] = a[2, 0] * s3 - a[2, 1] * s1 + a[2, 2] * s0
    o[0, 1] = o[1, 0] = -a[0, 1] * c5 + a[0, 2] * c4 - a[0, 3] * c3
    o[0, 2] = o[2, 0] = a[3, 1] * s5 - a[3, 2] * s4 + a[3, 3] * s3
    o[0, 3] = o[3, 0] = -a[2, 1] * s5 + a[2, 2] * s4 - a[2, 3] * s3
    o[1, 2] = o[2, 1] = -a[3, 0] * s5 + a[3, 2] * s2 - a[3, 3] * s1
    o[1, 3] = o[3, 1] = a[2, 0] * s5 - a[2, 2] * s2 + a[2, 3] * s1
    o[2, 3] = o[3, 2] = -a[2, 0] * s4 + a[2, 1] * s2 - a[2, 3] * s0


@njit(cache=True)
def quest_batch(b: np.ndarray, r: np.ndarray, a: np.ndarray, newton_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """QUEST for ``b`` (n, k, 3) against ``r`` (n, k, 3) (or (1, k, 3): the same for all) with weights ``a`` (k,)."""
    n, k = b.shape[0], b.shape[1]
    q = np.empty((n, 4))
    loss = np.empty(n)
    asum = a.sum()
    bu = np.empty((k, 3))
    ru = np.empty((k, 3))
    B = np.empty((3, 3))
    K = np.empty((4, 4))
    M = np.empty((4, 4))
    adj = np.empty((4, 4))
    K2 = np.empty((4, 4))
    same_ref = r.shape[0] == 1
    for s in range(n):
        bad = False
        for i in range(k):
            rs = 0 if same_ref else s
            nb = math.sqrt(b[s, i, 0] ** 2 + b[s, i, 1] ** 2 + b[s, i, 2] ** 2)
            nr = math.sqrt(r[rs, i, 0] ** 2 + r[rs, i, 1] ** 2 + r[rs, i, 2] ** 2)
            if not (nb > 0.0) or not (nr > 0.0) or not math.isfinite(nb) or not math.isfinite(nr):
                bad = True
                break
            for c in range(3):
                bu[i, c] = b[s, i, c] / nb
                ru[i, c] = r[rs, i, c] / nr
        if bad:
            q[s, :] = np.nan
            loss[s] = np.nan
            continue
        for p in range(3):
            for c in range(3):
                acc = 0.0
                for i in range(k):
                    acc += a[i] * bu[i, p] * ru[i, c]
                B[p, c] = acc
        sig = B[0, 0] + B[1, 1] + B[2, 2]
        K[0, 0] = sig
        K[0, 1] = K[1, 0] = B[1, 2] - B[2, 1]
        K[0, 2] = K[2, 0] = B[2, 0] - B[0, 2]
        K[0, 3] = K[3, 0] = B[0, 1] - B[1, 0]
        for i in range(3):
            for j in range(3):
                K[i + 1, j + 1] = B[i, j] + B[j, i] - (sig if i == j else 0.0)
        if k == 2:
            cb = bu[0, 0] * bu[1, 0] + bu[0, 1] * bu[1, 1] + bu[0, 2] * bu[1, 2]
            cr = ru[0, 0] * ru[1, 0] + ru[0, 1] * ru[1, 1] + ru[0, 2] * ru[1, 2]
            sb = math.sqrt(max(1.0 - cb * cb, 0.0))
            sr = math.sqrt(max(1.0 - cr * cr, 0.0))
            lam = math.sqrt(max(a[0] ** 2 + a[1] ** 2 + 2 * a[0] * a[1] * (cb * cr + sb * sr), 0.0))
        else:
            for i in range(4):
                for j in range(4):
                    acc = 0.0
                    for m in range(4):
                        acc += K[i, m] * K[m, j]
                    K2[i, j] = acc
            c2 = -0.5 * (K2[0, 0] + K2[1, 1] + K2[2, 2] + K2[3, 3])
            t3 = 0.0
            for i in range(4):
                for j in range(4):
                    t3 += K2[i, j] * K[j, i]
            c1 = -t3 / 3.0
            _adj4_sym(K, adj)
            c0 = K[0, 0] * adj[0, 0] + K[0, 1] * adj[1, 0] + K[0, 2] * adj[2, 0] + K[0, 3] * adj[3, 0]
            lam = 1.0
            for _ in range(newton_steps):
                pv = ((lam * lam + c2) * lam + c1) * lam + c0
                dp = (4 * lam * lam + 2 * c2) * lam + c1
                if dp != 0.0:
                    lam = lam - pv / dp
        for i in range(4):
            for j in range(4):
                M[i, j] = (lam if i == j else 0.0) - K[i, j]
        _adj4_sym(M, adj)
        tr = adj[0, 0] + adj[1, 1] + adj[2, 2] + adj[3, 3]
        col = 0
        if abs(adj[0, 0]) < 0.25 * abs(tr):
            best = -1.0
            for j in range(4):
                if abs(adj[j, j]) > best:
                    best = abs(adj[j, j])
                    col = j
        nq = math.sqrt(adj[0, col] ** 2 + adj[1, col] ** 2 + adj[2, col] ** 2 + adj[3, col] ** 2)
        sgn = -1.0 if adj[0, col] / nq < 0 else 1.0
        for i in range(4):
            q[s, i] = sgn * adj[i, col] / nq
        loss[s] = asum - lam
    return q, loss
