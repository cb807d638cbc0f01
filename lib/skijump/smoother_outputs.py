"""``rts-smooth``'s output columns from the smoothed states: estimates, standard deviations, constraint
values, and their interpolation onto the table's rows.

The last stage of ``rts-smooth`` (:mod:`sportfusion.skijump.smoother`): arrays of the engine's run and the
inputs in, named columns out.  :func:`_std_from_cov` is the numpy reference of the standard deviations the
C loop computes in its backward pass (``_ski_c.c``'s ``std_row``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from sportfusion.core import rotations
from sportfusion.skijump import model as mdl
from sportfusion.skijump.kinematics import m_bo, m_no
from sportfusion.skijump.smoother_inputs import SkiJumpInputs, segments


def _interp_rows(t_rows: np.ndarray, t: np.ndarray, values: np.ndarray, max_gap: float) -> np.ndarray:
    """Values at the steps -> every table row (linear in time; NaN outside the IMU segments)."""
    out = np.full((t_rows.size, values.shape[1]), np.nan)
    for a, b in segments(t, max_gap):
        inside = (t_rows >= t[a]) & (t_rows <= t[b - 1])
        for j in range(values.shape[1]):
            out[inside, j] = np.interp(t_rows[inside], t[a:b], values[a:b, j])
    return out


def euler_jacobian(q: np.ndarray) -> np.ndarray:
    """d(roll, pitch, yaw)/dq (n, 3, 4) of :func:`sportfusion.core.rotations.euler_from_quat` at ``q`` (n, 4).

    Analytic: roll and yaw are ``atan2`` of two entries of ``M_BO`` (quadratic in q, so the
    scale of q cancels) and pitch is ``asin(-m02 / |q|^2)``; the derivative is taken with
    respect to the raw (not necessarily unit) quaternion, as the angles normalise it.
    """
    q0, q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    m12, m22 = 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    m01, m00 = 2 * (q1 * q2 + q0 * q3), q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    m02 = 2 * (q1 * q3 - q0 * q2)
    d12 = 2 * np.stack((q1, q0, q3, q2), axis=-1)
    d22 = 2 * np.stack((q0, -q1, -q2, q3), axis=-1)
    d01 = 2 * np.stack((q3, q2, q1, q0), axis=-1)
    d00 = 2 * np.stack((q0, q1, -q2, -q3), axis=-1)
    d02 = 2 * np.stack((-q2, q3, -q0, q1), axis=-1)
    J = np.empty((q.shape[0], 3, 4))
    J[:, 0] = (m22[:, None] * d12 - m12[:, None] * d22) / (m12 * m12 + m22 * m22)[:, None]
    sp = -m02 / n2
    dsp = -(d02 * n2[:, None] - m02[:, None] * 2 * q) / (n2 * n2)[:, None]
    J[:, 1] = dsp / np.sqrt(np.maximum(1.0 - sp * sp, 1e-300))[:, None]
    J[:, 2] = (m00[:, None] * d01 - m01[:, None] * d00) / (m01 * m01 + m00 * m00)[:, None]
    return J


def interp_columns(
    t_rows: np.ndarray, t: np.ndarray, cols: dict[str, np.ndarray], max_gap: float, consume: bool = False
) -> dict[str, np.ndarray]:
    """:func:`_interp_rows` column by column (no (rows, columns) stack): ``cols`` at the steps ``t`` [s] ->
    the table's rows ``t_rows`` [s], linear in time, NaN outside the IMU segments (gaps over ``max_gap``).

    ``consume``: each column is taken out of ``cols`` as it is interpolated (``cols`` is left empty), so that
    the columns at the steps are freed along the way rather than held beside all the new ones (issue 38)."""
    segs = segments(t, max_gap)
    inside = [(a, b, np.flatnonzero((t_rows >= t[a]) & (t_rows <= t[b - 1]))) for a, b in segs]
    out = {}
    for name in list(cols):
        v = cols.pop(name) if consume else cols[name]
        o = np.full(t_rows.size, np.nan)
        for a, b, rows in inside:
            o[rows] = np.interp(t_rows[rows], t[a:b], v[a:b])
        out[name] = o
    return out


def estimate_columns(
    x: np.ndarray,
    cov: Callable[..., np.ndarray] | None,
    inp: SkiJumpInputs,
    prefix: str = "",
    var: Callable[[], np.ndarray] | None = None,
    std: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Named estimate columns (at the steps) from states (n, 22) and covariances (n, 22, 22).

    ``std`` (n, 28): the standard deviations computed in the compiled backward pass (states, hill-frame
    velocity, Euler angles); without it they come from ``cov``/``var`` here (the reference).
    """
    # Every column is made contiguous here (a table column without a copy): vectors are formed component by
    # component, or into the rows of (3, n) arrays; where x and std come from the C engine's column-major
    # arrays (_ski_native.column_outputs), their columns are contiguous as they are
    n = x.shape[0]
    q = x[:, 6:10]
    n2 = q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3]
    nq = np.sqrt(n2)
    M = m_bo(q)
    v_o, v_n = np.empty((3, n)), np.empty((3, n))
    np.einsum("nji,nj->ni", M, x[:, 3:6], out=v_o.T)
    rotations.ned_to_local(v_o.T, inp.azimuth_deg, out=v_n.T)  # the one NED -> hill-frame rotation
    roll, pitch, yaw = rotations.euler_from_dcm(M, scale=n2)  # M_BO of the raw quaternion: |q|^2 a rotation
    cols: dict[str, np.ndarray] = {}
    for k, a in enumerate("xyz"):
        cols[prefix + a] = x[:, k]
    for k, a in enumerate("xyz"):
        cols[f"{prefix}v{a}"] = v_n[k]
    for k in range(4):
        cols[f"{prefix}q{k}"] = q[:, k] / nq
    cols[prefix + "roll"], cols[prefix + "pitch"], cols[prefix + "yaw"] = roll, pitch, yaw
    if prefix:
        return cols
    for name, sl in (("bias_gyr", mdl.I_BG), ("bias_acc", mdl.I_BA), ("bias_mag", mdl.I_BM), ("scale_mag", mdl.I_SM)):
        for k, a in enumerate("xyz"):
            cols[f"{name}_{a}"] = x[:, sl][:, k]
    # eq 50: the magnetometer the estimate predicts (the paper's Figure 12 sets it beside the measurement)
    m_o = inp.m_o
    for k, a in enumerate("xyz"):
        b_k = M[:, k, 0] * m_o[0] + M[:, k, 1] * m_o[1] + M[:, k, 2] * m_o[2]
        cols[f"mag_pred_{a}"] = (1.0 + x[:, mdl.I_SM.start + k]) * b_k + x[:, mdl.I_BM.start + k]
    if cov is None and std is None:
        return cols
    if std is not None:
        d, sv, se = std[:, : mdl.N], std[:, mdl.N : mdl.N + 3], std[:, mdl.N + 3 :]
    else:
        d, sv, se = _std_from_cov(x, cov, inp, var)
    for k, a in enumerate("xyz"):
        cols[f"std_{a}"] = d[:, k]
    for k, a in enumerate("xyz"):
        cols[f"std_v{a}"] = sv[:, k]
    for k in range(4):
        cols[f"std_q{k}"] = d[:, 6 + k]
    for k, a in enumerate(("roll", "pitch", "yaw")):
        cols[f"std_{a}"] = se[:, k]
    for name, sl in (("bias_gyr", mdl.I_BG), ("bias_acc", mdl.I_BA), ("bias_mag", mdl.I_BM), ("scale_mag", mdl.I_SM)):
        for k, a in enumerate("xyz"):
            cols[f"std_{name}_{a}"] = d[:, sl][:, k]
    return cols


def _std_from_cov(
    x: np.ndarray, cov: Callable[..., np.ndarray], inp: SkiJumpInputs, var: Callable[[], np.ndarray] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard deviations of the states (n, 22), hill-frame velocity (n, 3) and Euler angles (n, 3) from the
    smoothed covariances (numpy; the reference of the compiled backward pass's ``std`` rows)."""
    mno = m_no(math.radians(inp.azimuth_deg))
    q = x[:, 6:10]
    M = m_bo(q)
    if var is not None:
        d = np.sqrt(np.maximum(var(), 0.0))
    else:
        d = np.sqrt(np.maximum(np.stack([cov(np.array([i]))[:, 0, 0] for i in range(mdl.N)], axis=-1), 0.0))
    # in blocks of rows: the Jacobians' temporaries stay small (memory per step, not per session)
    sv, se = np.empty((x.shape[0], 3)), np.empty((x.shape[0], 3))
    for r0 in range(0, x.shape[0], 8192):
        r = slice(r0, r0 + 8192)
        P = cov(np.arange(3, 10), r0, r0 + 8192)  # (m, 7, 7): v_B and q, this block only
        # hill-frame velocity: J = M_NO [M^T, d(M^T v)/dq] over (v_B, q)
        dm = mdl.dm_dq(q[r])  # (m, 4, 3, 3)
        Jv = np.einsum("ij,nkj->nik", mno, M[r])  # (m,3,3)  M_NO M^T
        Jq = np.einsum("ab,nkib,ni->nak", mno, dm, x[r, 3:6])  # (m,3,4)  M_NO dM_k^T v
        J = np.concatenate([Jv, Jq], axis=2)
        Cv = np.einsum("nij,njk,nlk->nil", J, P, J, optimize=True)
        sv[r] = np.sqrt(np.maximum(np.diagonal(Cv, axis1=1, axis2=2), 0.0))
        # Euler angles: analytic Jacobian w.r.t. q
        Je = euler_jacobian(q[r])
        Ce = np.einsum("nij,njk,nlk->nil", Je, P[:, 3:7, 3:7], Je, optimize=True)
        se[r] = np.sqrt(np.maximum(np.diagonal(Ce, axis1=1, axis2=2), 0.0))
    return d, sv, se


def constraint_residuals(x: np.ndarray, inp: SkiJumpInputs, hill_constraints: bool = True) -> dict[str, np.ndarray]:
    """Constraint values (eq 51) at the states ``x`` (n, 22): NaN where a hill constraint is inactive (all of
    them without ``hill_constraints`` or without the hill's profile in ``inp``)."""
    out = {"c_q": np.linalg.norm(x[:, 6:10], axis=1) - 1.0}
    nan = np.full(x.shape[0], np.nan)
    if not hill_constraints or inp.profile is None:
        out.update(c_v_ir=nan, c_h_ir=nan.copy(), c_v_la=nan.copy())
        return out
    ir, la = inp.profile
    out["c_v_ir"] = np.where(inp.inrun, x[:, 2] - ir.many(x[:, 0]), np.nan)
    out["c_h_ir"] = np.where(inp.inrun, x[:, 1], np.nan)
    out["c_v_la"] = np.where(inp.landing > 0, x[:, 2] - la.many(x[:, 0]), np.nan)
    return out


def residual_rms(residuals: dict[str, np.ndarray]) -> dict[str, float]:
    """RMS of each residual block over its finite entries (NaN where a step had no such update).

    Parameters
    ----------
    residuals : dict of str to array, shape (n, w)
        The smoother's residuals by update (units of the update: m, m/s, µT, 1).

    Returns
    -------
    dict of str to float
        Only the blocks with at least one update.
    """
    out = {}
    for k, v in residuals.items():
        s = np.square(v)
        m = ~np.isnan(s)  # one pass for the mask, one for the sum: no copy with NaN zeroed (np.nanmean)
        n = np.count_nonzero(m)
        if n:
            out[k] = math.sqrt(float(np.sum(s, where=m)) / n)
    return out
