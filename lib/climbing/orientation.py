"""Initial orientation for the transition estimator (§III-A, step 1).

The paper precomputes the orientations with the orientation estimator of Seel
and Ruppin; any estimator that is close enough for Gauss-Newton to converge
will do, so this is a plain Mahony-type complementary filter: gyroscope
integration (bias removed), pulled towards the accelerometer's "up" when the
specific force is close to gravity and towards the magnetometer's field
direction.  The start is a TRIAD fit of the first samples.
"""

from __future__ import annotations

import math

import numpy as np

from sportfusion.climbing._native import native


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def triad(f_body: np.ndarray, m_body: np.ndarray, up: np.ndarray, m_world: np.ndarray) -> np.ndarray:
    """Sensor-to-world rotation that maps the body's specific force onto ``up`` (exactly)
    and its field onto the plane of ``up`` and ``m_world``."""
    b1 = _unit(f_body)
    b2 = _unit(np.cross(b1, m_body))
    w1 = _unit(up)
    w2 = _unit(np.cross(w1, m_world))
    bm = np.column_stack([b1, b2, np.cross(b1, b2)])
    wm = np.column_stack([w1, w2, np.cross(w1, w2)])
    return wm @ bm.T


def complementary_filter(
    t: np.ndarray,
    acc: np.ndarray,
    gyr: np.ndarray,
    mag: np.ndarray,
    m_world: np.ndarray,
    up: np.ndarray,
    gravity: float,
    gyr_bias: np.ndarray | None = None,
    k_acc: float = 2.0,
    k_mag: float = 1.0,
    acc_gate: float = 1.5,
) -> np.ndarray:
    """Sensor-to-world rotations (n, 3, 3) from IMU and magnetometer samples.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times [s].
    acc, gyr, mag : numpy.ndarray, shape (n, 3)
        Specific force [m/s^2], angular rate [rad/s], magnetic field (any unit; NaN rows skipped).
    m_world, up : numpy.ndarray, shape (3,)
        Reference field direction and up axis in the world (map) frame.
    gravity : float
        [m/s^2]
    gyr_bias : numpy.ndarray, optional
        Gyroscope bias removed before integration [rad/s].
    k_acc, k_mag : float
        Correction gains [1/s].
    acc_gate : float
        The accelerometer corrects only when ``||f| - g|`` is below this [m/s^2].
    """
    n = t.size
    b = np.zeros(3) if gyr_bias is None else np.asarray(gyr_bias, dtype=np.float64)
    mag_ok = np.isfinite(mag).all(axis=1)
    head = slice(0, max(1, min(n, 10)))
    f0 = np.nanmean(acc[head], axis=0)
    m0 = np.nanmean(mag[head][mag_ok[head]], axis=0) if mag_ok[head].any() else np.cross(f0, [1.0, 0.0, 0.0])
    r = triad(f0, m0, up, m_world)
    upw = _unit(up)
    mw = _unit(m_world)
    fn = np.linalg.norm(acc, axis=1)
    fh = acc / np.where(fn > 0, fn, 1.0)[:, None]
    mn = np.linalg.norm(np.nan_to_num(mag), axis=1)
    mh = np.nan_to_num(mag) / np.where(mn > 0, mn, 1.0)[:, None]
    ka = np.where(np.abs(fn - gravity) < acc_gate, k_acc, 0.0)
    km = np.where(mag_ok, k_mag, 0.0)
    w = gyr - b
    dt = np.diff(t)
    ext = native()
    if ext is not None:  # the loop below in C (the same operations; this loop is its reference)
        c64 = np.ascontiguousarray
        out = np.empty((n, 3, 3))
        ext.complementary(n, c64(fh), c64(mh), c64(w), c64(ka), c64(km), c64(dt), c64(r), c64(upw), c64(mw), out)
        return out  # re-orthonormalised there (the polar factor, as the SVD below)
    # scalar loop (numpy's per-call overhead dominates 3-vectors): R row-major in r0..r8
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = (float(v) for v in r.ravel())
    ux, uy, uz = (float(v) for v in upw)
    mx, my, mz = (float(v) for v in mw)
    fl, ml, wl, kal, kml = fh[:-1].tolist(), mh[:-1].tolist(), w[:-1].tolist(), ka[:-1].tolist(), km[:-1].tolist()
    dtl = dt.tolist()
    rows = [(r0, r1, r2, r3, r4, r5, r6, r7, r8)]
    for (fx, fy, fz), (hx, hy, hz), (wx, wy, wz), a, m_, d in zip(fl, ml, wl, kal, kml, dtl, strict=True):
        # predicted up and field in the body frame: R^T u, R^T m
        bx, by, bz = r0 * ux + r3 * uy + r6 * uz, r1 * ux + r4 * uy + r7 * uz, r2 * ux + r5 * uy + r8 * uz
        cx, cy, cz = r0 * mx + r3 * my + r6 * mz, r1 * mx + r4 * my + r7 * mz, r2 * mx + r5 * my + r8 * mz
        ex = a * (fy * bz - fz * by) + m_ * (hy * cz - hz * cy)
        ey = a * (fz * bx - fx * bz) + m_ * (hz * cx - hx * cz)
        ez = a * (fx * by - fy * bx) + m_ * (hx * cy - hy * cx)
        px, py, pz = (wx + ex) * d, (wy + ey) * d, (wz + ez) * d
        th2 = px * px + py * py + pz * pz
        if th2 < 1e-18:
            sa, sb = 1.0, 0.5
        else:
            th = math.sqrt(th2)
            sa, sb = math.sin(th) / th, (1.0 - math.cos(th)) / th2
        # E = I + sa K + sb K^2, K = [p]x
        e0 = 1.0 - sb * (py * py + pz * pz)
        e4 = 1.0 - sb * (px * px + pz * pz)
        e8 = 1.0 - sb * (px * px + py * py)
        e1, e3 = -sa * pz + sb * px * py, sa * pz + sb * px * py
        e2, e6 = sa * py + sb * px * pz, -sa * py + sb * px * pz
        e5, e7 = -sa * px + sb * py * pz, sa * px + sb * py * pz
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = (
            r0 * e0 + r1 * e3 + r2 * e6,
            r0 * e1 + r1 * e4 + r2 * e7,
            r0 * e2 + r1 * e5 + r2 * e8,
            r3 * e0 + r4 * e3 + r5 * e6,
            r3 * e1 + r4 * e4 + r5 * e7,
            r3 * e2 + r4 * e5 + r5 * e8,
            r6 * e0 + r7 * e3 + r8 * e6,
            r6 * e1 + r7 * e4 + r8 * e7,
            r6 * e2 + r7 * e5 + r8 * e8,
        )
        rows.append((r0, r1, r2, r3, r4, r5, r6, r7, r8))
    out = np.array(rows).reshape(n, 3, 3)
    # re-orthonormalise (rounding drift over thousands of products)
    u, _, vt = np.linalg.svd(out)
    return u @ vt
