"""Attitude from vector observations: Wahba's problem solved by QUEST, batched in numpy.

Wahba's loss (skiracing-splines eq 8) for unit body vectors ``b_i``, unit
reference vectors ``r_i`` (local level, NED) and weights ``a_i`` (normalised
to sum 1 here)::

    J(q) = 1/2 sum_i a_i |b_i - M_BO(q) r_i|^2 = sum_i a_i - q^T K q

with Davenport's 4x4 matrix (scalar-first ordering)::

    B = sum_i a_i b_i r_i^T,  S = B + B^T,  sigma = tr B,
    z = [B23 - B32, B31 - B13, B12 - B21],
    K = [[sigma, z^T], [z, S - sigma I]].

The optimal ``q_BO`` is the eigenvector of ``K``'s largest eigenvalue
``lambda_max`` and the minimum loss is ``sum a_i - lambda_max`` (the
``quest_loss`` column).  QUEST (Shuster & Oh 1981) finds ``lambda_max`` from
the characteristic equation (closed form for two vectors, Newton-Raphson
otherwise) and the eigenvector from the adjugate of ``lambda_max I - K``.
Shuster's formula uses the adjugate's scalar column, which fails near 180
degree rotations; here the column with the largest diagonal element is used,
which is equivalent to the method of sequential rotations and valid for every
attitude.  :func:`davenport` is the brute-force eigen-decomposition reference.
"""

from __future__ import annotations

import math

import numpy as np


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / n


def _profile(body: np.ndarray, ref: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Attitude profile matrix B (N,3,3) and normalised weights (k,)."""
    a = np.asarray(weights, float)
    a = a / a.sum()
    b = _unit(np.asarray(body, float))
    r = _unit(np.asarray(ref, float))
    r = np.broadcast_to(r, b.shape)
    return np.einsum("k,nki,nkj->nij", a, b, r), a


def _davenport_k(B: np.ndarray) -> np.ndarray:
    S = B + np.swapaxes(B, -1, -2)
    sigma = np.trace(B, axis1=-2, axis2=-1)
    z = np.stack((B[:, 1, 2] - B[:, 2, 1], B[:, 2, 0] - B[:, 0, 2], B[:, 0, 1] - B[:, 1, 0]), axis=-1)
    K = np.empty(B.shape[:-2] + (4, 4))
    K[:, 0, 0] = sigma
    K[:, 0, 1:] = z
    K[:, 1:, 0] = z
    K[:, 1:, 1:] = S - sigma[:, None, None] * np.eye(3)
    return K


def davenport(body: np.ndarray, ref: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference solution of Wahba's problem: the top eigenvector of Davenport's K (``numpy.linalg.eigh``).

    Parameters as :func:`quest`.  Returns ``(q_BO (N,4) with q0 >= 0, loss (N,))``.
    """
    B, a = _profile(body, ref, weights)
    vals, vecs = np.linalg.eigh(_davenport_k(B))
    q = vecs[:, :, -1]
    q = np.where(q[:, :1] < 0, -q, q)
    return q, a.sum() - vals[:, -1]


def quest(
    body: np.ndarray, ref: np.ndarray, weights: np.ndarray, newton_steps: int = 8, chunk: int = 16384
) -> tuple[np.ndarray, np.ndarray]:
    """Solve Wahba's problem for every sample at once (QUEST).

    Parameters
    ----------
    body : array (N, k, 3)
        Body-frame observation vectors (any length; normalised here).
    ref : array (N, k, 3) or (k, 3)
        The same directions in the reference (NED) frame.
    weights : array (k,)
        Relative weights ``a_i`` (normalised to sum 1).
    newton_steps : int
        Newton-Raphson steps on the characteristic polynomial from
        ``lambda = 1`` when k > 2 (for k = 2 the closed form is exact).
    chunk : int
        Samples processed per block (keeps the work arrays in cache).

    Returns
    -------
    q : array (N, 4)
        ``q_BO`` (scalar first, ``q0 >= 0``), mapping NED into the body frame.
    loss : array (N,)
        Wahba's loss at the optimum, ``1 - lambda_max`` in [0, 2] (0: the
        observations agree exactly).  NaN where an input vector is zero or NaN.
    """
    a = np.asarray(weights, float)
    a = a / a.sum()
    b = np.asarray(body, float)
    r = np.asarray(ref, float)
    n = b.shape[0]
    if n == 1:  # one attitude (an alignment): the same steps on Python floats, ~20x less overhead than arrays
        q1, loss1 = _quest_one(b[0], r[0] if r.ndim == 3 else r, a, newton_steps)
        return q1[None], np.array([loss1])
    q = np.empty((n, 4))
    loss = np.empty(n)
    for s in range(0, n, chunk):
        e = min(s + chunk, n)
        rr = r if r.ndim == 2 else r[s:e]
        q[s:e], loss[s:e] = _quest_block(b[s:e], rr, a, newton_steps)
    return q, loss


def _quest_block(b: np.ndarray, r: np.ndarray, a: np.ndarray, newton_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """QUEST on one block, component arrays (struct of arrays) for speed."""
    k = b.shape[1]
    bu = np.ascontiguousarray(b.transpose(1, 2, 0))  # (k, 3, m)
    with np.errstate(invalid="ignore", divide="ignore"):
        bu /= np.sqrt(bu[:, 0] ** 2 + bu[:, 1] ** 2 + bu[:, 2] ** 2)[:, None]
    ru = _unit(r)
    ru = ru[:, :, None] if ru.ndim == 2 else np.ascontiguousarray(ru.transpose(1, 2, 0))  # (k, 3, m|1)
    if k > 4:  # many vectors (few samples): one contraction instead of k products per entry
        Bm = np.einsum("i,ipm,icm->pcm", a, bu, np.broadcast_to(ru, (k, 3, bu.shape[2])))
        B = [[Bm[p, c] for c in range(3)] for p in range(3)]
    else:
        B = [[sum(a[i] * bu[i, p] * ru[i, c] for i in range(k)) for c in range(3)] for p in range(3)]
    sig = B[0][0] + B[1][1] + B[2][2]
    z = (B[1][2] - B[2][1], B[2][0] - B[0][2], B[0][1] - B[1][0])
    # K (scalar first) as symmetric entries k_ij
    K = [[None] * 4 for _ in range(4)]
    K[0][0] = sig
    for i in range(3):
        K[0][i + 1] = K[i + 1][0] = z[i]
        for j in range(3):
            K[i + 1][j + 1] = B[i][j] + B[j][i] - (sig if i == j else 0.0)
    if k == 2:
        b0, b1 = bu[0], bu[1]
        r0, r1 = ru[0], ru[1]
        cb = b0[0] * b1[0] + b0[1] * b1[1] + b0[2] * b1[2]
        cr = r0[0] * r1[0] + r0[1] * r1[1] + r0[2] * r1[2]
        sb = np.sqrt(np.maximum(1.0 - cb * cb, 0.0))
        sr = np.sqrt(np.maximum(1.0 - cr * cr, 0.0))
        lam = np.sqrt(np.maximum(a[0] ** 2 + a[1] ** 2 + 2 * a[0] * a[1] * (cb * cr + sb * sr), 0.0))
        lam = np.broadcast_to(lam, sig.shape)
    else:
        Kn = np.moveaxis(np.array([[np.broadcast_to(K[i][j], sig.shape) for j in range(4)] for i in range(4)]), -1, 0)
        K2 = Kn @ Kn
        c2 = -0.5 * np.trace(K2, axis1=-2, axis2=-1)
        c1 = -np.einsum("nij,nji->n", K2, Kn) / 3.0
        c0 = np.linalg.det(Kn)
        lam = np.ones_like(sig)
        for _ in range(newton_steps):
            p = ((lam * lam + c2) * lam + c1) * lam + c0
            dp = (4 * lam * lam + 2 * c2) * lam + c1
            with np.errstate(invalid="ignore", divide="ignore"):
                lam = lam - np.where(dp != 0, p / dp, 0.0)
    M = [[(lam if i == j else 0.0) - K[i][j] for j in range(4)] for i in range(4)]
    adj = _adj4_sym(M)
    # adj = c q q^T: Shuster's scalar column unless q0 is small (near 180 deg), then the best column
    qs = np.stack([np.broadcast_to(adj[i][0], sig.shape) for i in range(4)], axis=-1)
    tr = adj[0][0] + adj[1][1] + adj[2][2] + adj[3][3]
    with np.errstate(invalid="ignore", divide="ignore"):
        bad = np.abs(adj[0][0]) < 0.25 * np.abs(tr)
    if bad.any():
        A = np.array([[np.broadcast_to(adj[i][j], sig.shape)[bad] for j in range(4)] for i in range(4)])
        col = np.argmax(np.abs(np.einsum("iin->in", A)), axis=0)
        qs[bad] = A[:, col, np.arange(col.size)].T
    with np.errstate(invalid="ignore", divide="ignore"):
        qs /= np.sqrt(np.sum(qs * qs, axis=-1, keepdims=True))
    qs *= np.where(qs[:, :1] < 0, -1.0, 1.0)
    return qs, a.sum() - lam


def _quest_one(b: np.ndarray, r: np.ndarray, a: np.ndarray, newton_steps: int) -> tuple[np.ndarray, float]:
    """QUEST for one sample: ``b``, ``r`` (k, 3), ``a`` (k,) normalised; the steps of :func:`_quest_block`
    (profile matrix, characteristic polynomial, Newton-Raphson, adjugate column) on Python floats.
    Returns ``(q (4,), loss)``; NaN where a vector is zero or NaN."""
    k = b.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        bu = b / np.sqrt(np.sum(b * b, axis=1))[:, None]
        ru = r / np.sqrt(np.sum(r * r, axis=1))[:, None]
    B = ((bu * a[:, None]).T @ ru).tolist()  # B[p][c] = sum_i a_i b_ip r_ic
    sig = B[0][0] + B[1][1] + B[2][2]
    z = (B[1][2] - B[2][1], B[2][0] - B[0][2], B[0][1] - B[1][0])
    K = [[sig, *z], [z[0], 0.0, 0.0, 0.0], [z[1], 0.0, 0.0, 0.0], [z[2], 0.0, 0.0, 0.0]]
    for i in range(3):
        for j in range(3):
            K[i + 1][j + 1] = B[i][j] + B[j][i] - (sig if i == j else 0.0)
    asum = float(a.sum())
    if k == 2:
        cb, cr = float(bu[0] @ bu[1]), float(ru[0] @ ru[1])
        sb, sr = math.sqrt(max(1.0 - cb * cb, 0.0)), math.sqrt(max(1.0 - cr * cr, 0.0))
        a0, a1 = float(a[0]), float(a[1])
        lam = math.sqrt(max(a0**2 + a1**2 + 2 * a0 * a1 * (cb * cr + sb * sr), 0.0))  # max(nan, 0.0) is nan
    else:
        K2 = [[sum(K[i][m] * K[m][j] for m in range(4)) for j in range(4)] for i in range(4)]
        c2 = -0.5 * (K2[0][0] + K2[1][1] + K2[2][2] + K2[3][3])
        c1 = -sum(K2[i][j] * K[j][i] for i in range(4) for j in range(4)) / 3.0
        adjk = _adj4_sym(K)
        c0 = sum(K[0][j] * adjk[j][0] for j in range(4))  # det K along its first row
        lam = 1.0
        for _ in range(newton_steps):
            p = ((lam * lam + c2) * lam + c1) * lam + c0
            dp = (4 * lam * lam + 2 * c2) * lam + c1
            lam = lam - (p / dp if dp != 0 else 0.0)
    M = [[(lam if i == j else 0.0) - K[i][j] for j in range(4)] for i in range(4)]
    adj = _adj4_sym(M)
    tr = adj[0][0] + adj[1][1] + adj[2][2] + adj[3][3]
    col = 0
    if abs(adj[0][0]) < 0.25 * abs(tr):  # near 180 deg: the column with the largest diagonal element
        col = max(range(4), key=lambda c: abs(adj[c][c]))
    q = np.array([adj[i][col] for i in range(4)])
    with np.errstate(invalid="ignore", divide="ignore"):
        q /= math.sqrt(float(q @ q))
    if q[0] < 0:
        q = -q
    return q, asum - lam


def _adj4_sym(a: list) -> list:
    """Adjugate of a symmetric 4x4 matrix given as nested lists of component arrays."""
    s0 = a[0][0] * a[1][1] - a[1][0] * a[0][1]
    s1 = a[0][0] * a[1][2] - a[1][0] * a[0][2]
    s2 = a[0][0] * a[1][3] - a[1][0] * a[0][3]
    s3 = a[0][1] * a[1][2] - a[1][1] * a[0][2]
    s4 = a[0][1] * a[1][3] - a[1][1] * a[0][3]
    s5 = a[0][2] * a[1][3] - a[1][2] * a[0][3]
    c5 = a[2][2] * a[3][3] - a[3][2] * a[2][3]
    c4 = a[2][1] * a[3][3] - a[3][1] * a[2][3]
    c3 = a[2][1] * a[3][2] - a[3][1] * a[2][2]
    c2 = a[2][0] * a[3][3] - a[3][0] * a[2][3]
    c1 = a[2][0] * a[3][2] - a[3][0] * a[2][2]
    o = [[None] * 4 for _ in range(4)]
    o[0][0] = a[1][1] * c5 - a[1][2] * c4 + a[1][3] * c3
    o[1][1] = a[0][0] * c5 - a[0][2] * c2 + a[0][3] * c1
    o[2][2] = a[3][0] * s4 - a[3][1] * s2 + a[3][3] * s0
    o[3][3] = a[2][0] * s3 - a[2][1] * s1 + a[2][2] * s0
    o[0][1] = o[1][0] = -a[0][1] * c5 + a[0][2] * c4 - a[0][3] * c3
    o[0][2] = o[2][0] = a[3][1] * s5 - a[3][2] * s4 + a[3][3] * s3
    o[0][3] = o[3][0] = -a[2][1] * s5 + a[2][2] * s4 - a[2][3] * s3
    o[1][2] = o[2][1] = -a[3][0] * s5 + a[3][2] * s2 - a[3][3] * s1
    o[1][3] = o[3][1] = a[2][0] * s5 - a[2][2] * s2 + a[2][3] * s1
    o[2][3] = o[3][2] = -a[2][0] * s4 + a[2][1] * s2 - a[2][3] * s0
    return o
