"""Block-tridiagonal systems (estimators.blocktri) against dense linear algebra: the numpy cyclic reduction
and, where it is built, the C block Cholesky."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from sportfusion.estimators import _banded, blocktri

C = _banded.native()


@pytest.fixture(autouse=True, params=["numpy", "c"])
def engine(request: pytest.FixtureRequest) -> Iterator[str]:
    """Every test with the cyclic reduction (numpy) and with the C block Cholesky."""
    if request.param == "c" and C is None:
        pytest.skip("the C extension sportfusion.estimators._banded_c is not built")
    saved = _banded._NATIVE
    _banded._NATIVE = C if request.param == "c" else None
    yield request.param
    _banded._NATIVE = saved


def _system(n: int, b: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, b, b))
    d = d @ np.swapaxes(d, 1, 2) + 2.0 * b * np.eye(b)
    e = rng.normal(size=(n - 1, b, b))
    a = np.zeros((n * b, n * b))
    for k in range(n):
        a[k * b : (k + 1) * b, k * b : (k + 1) * b] = d[k]
        if k + 1 < n:
            a[k * b : (k + 1) * b, (k + 1) * b : (k + 2) * b] = e[k]
            a[(k + 1) * b : (k + 2) * b, k * b : (k + 1) * b] = e[k].T
    return d, e, a


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 7, 8, 9, 16, 17, 100])
def test_solve_and_diagonal_of_the_inverse_match_dense(n: int) -> None:
    b = 6
    d, e, a = _system(n, b, seed=n)
    assert np.linalg.eigvalsh(a).min() > 0
    f = blocktri.factor(d, e)
    assert isinstance(f, blocktri.BlockCholesky) == (_banded._NATIVE is not None)
    rng = np.random.default_rng(0)
    r = rng.normal(size=(n, b, 3))
    x = blocktri.solve(f, r)
    ref = np.linalg.solve(a, r.reshape(n * b, 3)).reshape(n, b, 3)
    assert np.allclose(x, ref, rtol=1e-10, atol=1e-12)
    assert np.allclose(blocktri.solve(f, r[..., 0]), ref[..., 0], rtol=1e-10, atol=1e-12)  # one right-hand side
    r = rng.normal(size=(n, b, 37))  # more right-hand sides than the C products take at a time (16)
    ref = np.linalg.solve(a, r.reshape(n * b, 37)).reshape(n, b, 37)
    assert np.allclose(blocktri.solve(f, r), ref, rtol=1e-10, atol=1e-12)
    inv = np.linalg.inv(a)
    g = blocktri.diagonal_of_inverse(f)
    for k in range(n):
        assert np.allclose(g[k], inv[k * b : (k + 1) * b, k * b : (k + 1) * b], rtol=1e-10, atol=1e-13)


def test_a_matrix_that_is_not_positive_definite_is_refused() -> None:
    d, e, _ = _system(9, 2, seed=1)
    e[4] *= 100.0  # strong coupling: a Schur complement turns indefinite
    with pytest.raises(np.linalg.LinAlgError):
        blocktri.factor(d, e)


@pytest.mark.parametrize("n", [1, 2, 5, 8, 17])
def test_bordered_solve_and_inverse_blocks_match_dense(n: int) -> None:
    b, c = 6, 3
    d, e, a = _system(n, b, seed=100 + n)
    rng = np.random.default_rng(n)
    border = 0.3 * rng.normal(size=(n, b, c))
    corner = rng.normal(size=(c, c))
    corner = corner @ corner.T + 10.0 * n * np.eye(c)
    full = np.block([[a, border.reshape(n * b, c)], [border.reshape(n * b, c).T, corner]])
    assert np.linalg.eigvalsh(full).min() > 0
    f = blocktri.factor_bordered(d, e, border, corner)
    r, rc = rng.normal(size=(n, b)), rng.normal(size=c)
    x, xc = blocktri.solve_bordered(f, r, rc)
    ref = np.linalg.solve(full, np.r_[r.ravel(), rc])
    assert np.allclose(np.r_[x.ravel(), xc], ref, rtol=1e-10, atol=1e-12)
    inv = np.linalg.inv(full)
    g, gc, gb = blocktri.diagonal_of_inverse_bordered(f)
    assert np.allclose(gc, inv[n * b :, n * b :], rtol=1e-10, atol=1e-13)
    for k in range(n):
        sl = slice(k * b, (k + 1) * b)
        assert np.allclose(g[k], inv[sl, sl], rtol=1e-10, atol=1e-13)
        assert np.allclose(gb[k], inv[sl, n * b :], rtol=1e-10, atol=1e-13)


def test_the_two_factorisations_agree_on_a_large_system() -> None:
    if C is None:
        pytest.skip("the C extension sportfusion.estimators._banded_c is not built")
    d, e, _ = _system(300, 6, seed=3)
    r = np.random.default_rng(1).normal(size=(300, 6, 2))
    out = {}
    for name, mod in (("numpy", None), ("c", C)):
        _banded._NATIVE = mod
        f = blocktri.factor(d, e)
        out[name] = (blocktri.solve(f, r), blocktri.diagonal_of_inverse(f))
    assert np.allclose(out["numpy"][0], out["c"][0], rtol=1e-10, atol=1e-13)
    assert np.allclose(out["numpy"][1], out["c"][1], rtol=1e-10, atol=1e-14)


def test_the_c_kernels_check_their_arguments() -> None:
    if C is None:
        pytest.skip("the C extension sportfusion.estimators._banded_c is not built")
    z = np.zeros(36)
    with pytest.raises(ValueError, match="bad dimensions"):
        C.bt_factor(1, 33, z, z, z, z)
    with pytest.raises(ValueError, match="expected"):
        C.bt_solve(2, 6, 1, z, z, np.zeros(12))


@pytest.mark.parametrize("n", [1, 2, 9, 40000])
def test_factor_in_place_and_the_chunked_bordered_diagonal_match(n: int) -> None:
    """``factor(..., overwrite=True)`` (the factors in the system's own memory) and the diagonal of a bordered
    inverse formed a chunk at a time (40000 blocks: more than one chunk) give what the plain path gives."""
    b, c = 6, 6
    d, e, _ = _system(n, b, seed=7) if n < 100 else _system(2, b, seed=7)
    if n >= 100:  # a long system without its dense matrix
        rng = np.random.default_rng(7)
        d = rng.normal(size=(n, b, b))
        d = d @ np.swapaxes(d, 1, 2) + 2.0 * b * np.eye(b)
        e = 0.3 * rng.normal(size=(n - 1, b, b))
    rng = np.random.default_rng(n)
    border = 0.3 * rng.normal(size=(n, b, c))
    corner = rng.normal(size=(c, c))
    corner = corner @ corner.T + 10.0 * n * np.eye(c)
    plain = blocktri.factor_bordered(d, e, border, corner)
    d2, e2 = d.copy(), e.copy()
    inplace = blocktri.bordered(blocktri.factor(d2, e2, overwrite=True), border, corner)
    r, rc = rng.normal(size=(n, b)), rng.normal(size=c)
    x1, xc1 = blocktri.solve_bordered(plain, r, rc)
    x2, xc2 = blocktri.solve_bordered(inplace, r, rc)
    assert np.allclose(x1, x2, rtol=1e-12, atol=1e-14) and np.allclose(xc1, xc2, rtol=1e-12, atol=1e-14)
    g1, s1, gb1 = blocktri.diagonal_of_inverse_bordered(plain)
    g2, s2, gb2 = blocktri.diagonal_of_inverse_bordered(inplace, border=False)
    assert gb2 is None and np.allclose(s1, s2, rtol=1e-12)
    ys = plain.y @ plain.s_inv
    assert np.allclose(g1, blocktri.diagonal_of_inverse(plain.tri) + ys @ np.swapaxes(plain.y, 1, 2), rtol=1e-12)
    assert np.allclose(g1, g2, rtol=1e-12, atol=1e-15)
