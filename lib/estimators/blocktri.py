"""Symmetric positive definite block-tridiagonal systems by cyclic reduction, numpy only.

A matrix ``A`` of ``n x n`` blocks of size ``b`` with diagonal blocks ``D_k`` and ``A[k, k+1] = E_k``
(``A[k+1, k] = E_k^T``).  Odd-even cyclic reduction eliminates the even-numbered blocks of a level,

    x_j = D_j^-1 r_j - P_j x_j-1 - Q_j x_j+1,   P_j = D_j^-1 E_j-1^T,  Q_j = D_j^-1 E_j,

which leaves a block-tridiagonal system of half the size on the odd-numbered blocks (its diagonal
blocks are Schur complements of ``A``, so they stay positive definite):

    D'_k = D_k - E_k-1^T Q_k-1 - E_k P_k+1,   E'_k = -E_k Q_k+1,   r'_k = r_k - Q_k-1^T r_k-1 - P_k+1^T r_k+1.

After ``log2 n`` levels one block is left.  Every level is a handful of batched ``b x b`` products
and one batched inverse, so the work is O(n b^3) in O(log n) array operations (no loop over the
blocks, no LAPACK banded solver and no ``scipy.linalg`` import).  The diagonal blocks of ``A^-1``
(selected inversion) come back up the levels the same way: with ``G = A^-1``,

    G_jj = D_j^-1 + L_j P_j^T + R_j Q_j^T,   G_j,j-1 = -L_j,   G_j,j+1 = -R_j,
    L_j = P_j G_j-1,j-1 + Q_j G_j+1,j-1,      R_j = P_j G_j-1,j+1 + Q_j G_j+1,j+1,

from the diagonal and first off-diagonal blocks of the reduced system's inverse.  A level with an
even number of blocks gets a decoupled identity block appended (it changes nothing).

Where the optional C extension ``sportfusion.estimators._banded_c`` is built, :func:`factor` instead runs a
sequential block Cholesky in C, ``A = L L^T`` with the Cholesky factors ``L_k`` of the Schur complements
``S_k = D_k - W_k-1^T W_k-1``, ``W_k = L_k^-1 E_k``; the diagonal blocks of the inverse then come from
``G_k = L_k^-T (I + W_k G_k+1 W_k^T) L_k^-1``.  For thousands of 6 x 6 blocks its loops cost a fraction of
numpy's per-level calls; the cyclic reduction stays the reference and the fallback (tested against each other
and against dense algebra).

Bordered systems
----------------
Constant parameters (a sensor bias over the whole record) couple every block to a few extra
unknowns: the matrix becomes ``[[A, B], [B^T, C]]`` with ``A`` block tridiagonal, a dense border
``B`` (``n`` blocks of ``b x c``) and a corner ``C`` (``c x c``).  :func:`factor_bordered` eliminates
the blocks first (a Schur complement on the border): with ``Y = A^-1 B`` (``c`` right-hand sides of
the cyclic reduction) and ``S = C - B^T Y``,

    x_c = S^-1 (r_c - Y^T r),   x = A^-1 r - Y x_c,

and the inverse's blocks are ``A^-1 + Y S^-1 Y^T`` (diagonal), ``-Y S^-1`` (border) and ``S^-1``
(corner).  The work stays O(n b^2 c + n b^3): linear in ``n``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.estimators._banded import native as _native

__all__ = [
    "CyclicReduction",
    "BlockCholesky",
    "Bordered",
    "factor",
    "solve",
    "diagonal_of_inverse",
    "factor_bordered",
    "bordered",
    "solve_bordered",
    "diagonal_of_inverse_bordered",
]


@dataclass
class _Level:
    dinv: np.ndarray  # (ne, b, b) inverses of the eliminated (even) diagonal blocks
    p: np.ndarray  # (ne, b, b) D_j^-1 E_j-1^T (zero for the first)
    q: np.ndarray  # (ne, b, b) D_j^-1 E_j (zero for the last)
    padded: bool  # an identity block was appended to this level


@dataclass
class CyclicReduction:
    """A factorised block-tridiagonal matrix (from :func:`factor`)."""

    n: int
    levels: list[_Level]
    last: np.ndarray  # (1, b, b) inverse of the one block left


@dataclass
class BlockCholesky:
    """A factorised block-tridiagonal matrix (from :func:`factor` with the C extension): ``A = L L^T``, ``L``
    block lower bidiagonal with diagonal blocks ``l[k]`` (lower Cholesky factors of the Schur complements) and
    sub-diagonal blocks ``w[k]^T``, ``w[k] = l[k]^-1 E_k``."""

    n: int
    l: np.ndarray  # noqa: E741 - (n, b, b)
    w: np.ndarray  # (n - 1, b, b)


def _t(a: np.ndarray) -> np.ndarray:
    return np.swapaxes(a, -1, -2)


def _spd_inverse(d: np.ndarray) -> np.ndarray:
    """Inverses of positive definite blocks (..., b, b); LinAlgError when one is not positive definite."""
    li = np.linalg.inv(np.linalg.cholesky(d))
    return _t(li) @ li


def factor(d: np.ndarray, e: np.ndarray, overwrite: bool = False) -> CyclicReduction | BlockCholesky:
    """Cyclic reduction of the symmetric positive definite block-tridiagonal matrix (``D``, ``E``).

    Where the C extension is built (``sportfusion.estimators._banded_c``) the factorisation is instead a
    sequential block Cholesky in C (:class:`BlockCholesky`; the same solutions and inverse blocks to rounding,
    several times faster for many small blocks); :func:`solve` and :func:`diagonal_of_inverse` take either.

    Parameters
    ----------
    d : numpy.ndarray, shape (n, b, b)
        Diagonal blocks (symmetric).
    e : numpy.ndarray, shape (n - 1, b, b)
        Upper off-diagonal blocks ``A[k, k+1]``.

    overwrite : bool
        The block Cholesky may write its factors over ``d`` and ``e`` (no second pair of arrays as long as
        the matrix: a long system's memory); they are garbage afterwards.

    Returns
    -------
    CyclicReduction or BlockCholesky

    Raises
    ------
    numpy.linalg.LinAlgError
        When the matrix is not positive definite.
    """
    d = np.ascontiguousarray(d, dtype=np.float64)
    e = np.ascontiguousarray(e, dtype=np.float64)
    n, b = d.shape[0], d.shape[1]
    if n == 0:
        raise ValueError("no blocks")
    ext = _native()
    if ext is not None and b <= 32:
        in_place = overwrite and d.flags.writeable and e.flags.writeable and e.shape[0] == max(n - 1, 0)
        lf = d if in_place else np.empty_like(d)
        w = e if in_place else np.empty((max(n - 1, 0), b, b))
        bad = ext.bt_factor(n, b, d, e, lf, w)
        if bad >= 0:
            raise np.linalg.LinAlgError(f"block {bad} of the block-tridiagonal matrix: not positive definite")
        return BlockCholesky(n, lf, w)
    levels = []
    while d.shape[0] > 1:
        padded = d.shape[0] % 2 == 0
        if padded:
            d = np.concatenate((d, np.eye(b)[None]))
            e = np.concatenate((e, np.zeros((1, b, b))))
        dinv = _spd_inverse(d[0::2])
        e0, e1 = e[0::2], e[1::2]  # E_j of the even j (right couplings), E_j-1 of the even j >= 2
        p = np.zeros_like(dinv)
        q = np.zeros_like(dinv)
        p[1:] = dinv[1:] @ _t(e1)
        q[:-1] = dinv[:-1] @ e0
        d = d[1::2] - _t(e0) @ q[:-1] - e1 @ p[1:]
        e = -e1[:-1] @ q[1:-1]
        levels.append(_Level(dinv, p, q, padded))
    return CyclicReduction(n, levels, _spd_inverse(d))


def solve(f: CyclicReduction | BlockCholesky, r: np.ndarray) -> np.ndarray:
    """``A^-1 r`` for right-hand sides ``r`` of shape (n, b) or (n, b, c)."""
    r = np.asarray(r, dtype=np.float64)
    vec = r.ndim == 2
    if vec:
        r = r[..., None]
    if isinstance(f, BlockCholesky):
        x = np.array(r, dtype=np.float64, order="C")  # solved in place
        _native().bt_solve(f.n, f.l.shape[1], x.shape[2], f.l, f.w, x)
        return x[..., 0] if vec else x
    kept = []
    for lev in f.levels:
        if lev.padded:
            r = np.concatenate((r, np.zeros((1, *r.shape[1:]))))
        re = r[0::2]
        kept.append(re)
        r = r[1::2] - _t(lev.q[:-1]) @ re[:-1] - _t(lev.p[1:]) @ re[1:]
    x = f.last @ r
    for lev, re in zip(reversed(f.levels), reversed(kept), strict=True):
        xe = lev.dinv @ re
        xe[1:] -= lev.p[1:] @ x
        xe[:-1] -= lev.q[:-1] @ x
        full = np.empty((xe.shape[0] + x.shape[0], *x.shape[1:]))
        full[0::2], full[1::2] = xe, x
        x = full[:-1] if lev.padded else full
    return x[..., 0] if vec else x


def diagonal_of_inverse(f: CyclicReduction | BlockCholesky) -> np.ndarray:
    """The diagonal blocks (n, b, b) of ``A^-1`` (selected inversion, O(n b^3))."""
    if isinstance(f, BlockCholesky):
        g = np.empty_like(f.l)
        _native().bt_diag_inverse(f.n, f.l.shape[1], f.l, f.w, g)
        return g
    g = f.last  # diagonal blocks of the current level's inverse
    c = np.zeros((0, *g.shape[1:]))  # its first off-diagonal blocks G[k, k+1]
    for lev in reversed(f.levels):
        p, q = lev.p, lev.q
        left = np.zeros_like(lev.dinv)
        right = np.zeros_like(lev.dinv)
        left[1:] = p[1:] @ g
        left[1:-1] += q[1:-1] @ _t(c)
        right[:-1] = q[:-1] @ g
        right[1:-1] += p[1:-1] @ c
        ge = lev.dinv + left @ _t(p) + right @ _t(q)
        diag = np.empty((ge.shape[0] + g.shape[0], *g.shape[1:]))
        diag[0::2], diag[1::2] = ge, g
        off = np.empty((diag.shape[0] - 1, *g.shape[1:]))
        off[0::2] = -right[:-1]  # G[j, j+1], j even
        off[1::2] = -_t(left[1:])  # G[k, k+1] = G[k+1, k]^T, k odd
        g, c = (diag[:-1], off[:-1]) if lev.padded else (diag, off)
    return g


@dataclass
class Bordered:
    """A factorised bordered block-tridiagonal matrix ``[[A, B], [B^T, C]]`` (from :func:`factor_bordered`)."""

    tri: CyclicReduction | BlockCholesky  # A
    y: np.ndarray  # (n, b, c) A^-1 B
    s_inv: np.ndarray  # (c, c) inverse of the Schur complement S = C - B^T A^-1 B


def factor_bordered(d: np.ndarray, e: np.ndarray, border: np.ndarray, corner: np.ndarray) -> Bordered:
    """Factor ``[[A, B], [B^T, C]]``, ``A`` block tridiagonal (``d``, ``e``), by a Schur complement on the border.

    Parameters
    ----------
    d : numpy.ndarray, shape (n, b, b)
        Diagonal blocks of ``A`` (symmetric).
    e : numpy.ndarray, shape (n - 1, b, b)
        Upper off-diagonal blocks ``A[k, k+1]``.
    border : numpy.ndarray, shape (n, b, c)
        The border ``B``: block ``k`` couples the unknowns of block ``k`` to the ``c`` border unknowns.
    corner : numpy.ndarray, shape (c, c)
        ``C`` (symmetric).

    Returns
    -------
    Bordered

    Raises
    ------
    numpy.linalg.LinAlgError
        When the matrix is not positive definite.
    """
    return bordered(factor(d, e), border, corner)


def bordered(tri: CyclicReduction | BlockCholesky, border: np.ndarray, corner: np.ndarray) -> Bordered:
    """:func:`factor_bordered` from the factorised ``A`` (:func:`factor`): the caller may drop ``d`` and ``e``
    before the border's solves (a long system's memory)."""
    border = np.asarray(border, dtype=np.float64)
    y = solve(tri, border)
    s = np.asarray(corner, dtype=np.float64) - np.einsum("nbi,nbj->ij", border, y)
    s = 0.5 * (s + s.T)
    return Bordered(tri, y, _spd_inverse(s[None])[0])


def solve_bordered(f: Bordered, r: np.ndarray, rc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``[[A, B], [B^T, C]]^-1 [r; rc]`` for ``r`` (n, b) and ``rc`` (c,): returns ``(x, x_c)``."""
    r = np.asarray(r, dtype=np.float64)
    xa = solve(f.tri, r)
    xc = f.s_inv @ (np.asarray(rc, dtype=np.float64) - np.einsum("nbi,nb->i", f.y, r))
    return xa - np.einsum("nbi,i->nb", f.y, xc), xc


def diagonal_of_inverse_bordered(f: Bordered, border: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Blocks of ``[[A, B], [B^T, C]]^-1``: the diagonal (n, b, b), the corner (c, c) and the border (n, b, c)
    (None with ``border=False``: the diagonal alone is then formed without an (n, b, c) temporary)."""
    diag = diagonal_of_inverse(f.tri)
    if diag is getattr(f.tri, "last", None):
        diag = diag.copy()  # (one block: the factorisation's own array)
    step = 1 << 14
    for s in range(0, diag.shape[0], step):  # + Y S^-1 Y^T, a chunk at a time
        ys = f.y[s : s + step] @ f.s_inv
        diag[s : s + step] += ys @ _t(f.y[s : s + step])
    return diag, f.s_inv, (-(f.y @ f.s_inv) if border else None)
