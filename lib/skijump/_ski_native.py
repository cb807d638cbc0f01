"""The ski-jump C extension (``_ski_c.c``): the smoother's EKF + RTS loop, and two helpers of the alignment.

:mod:`sportfusion.skijump._ski_c` is built by ``setup.py`` as an optional extension and imports in about a
millisecond.  :func:`ski_ekf_rts` allocates the outputs and calls its loop; the engine
(:mod:`sportfusion.skijump.smoother_engine`) is its one caller, and its numpy reference is
:func:`sportfusion.estimators.kalman.ekf_rts` with the engine's ``model_callables``.  Without the extension (no
C compiler at install time, or ``SPORTFUSION_NATIVE=0`` in the environment) :func:`native` is None and the
engine runs that reference.  The alignment's gyro product and latency misfit
(:mod:`sportfusion.skijump.alignment`) use the extension's two other functions where it is built.  This
module also holds the loop's layout (packed covariances, residual and std columns).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from sportfusion.core.native import load_extension

N = 22
NP = N * (N + 1) // 2
#: Columns of the standard-deviation rows: the 22 states, the hill-frame velocity (3), roll/pitch/yaw (3).
NSTD = N + 6
#: Residual blocks returned by ``ski_ekf_rts`` (name, width).
RESIDUALS = (
    ("c_q", 1),
    ("gnss_pos", 3),
    ("gnss_vel", 3),
    ("mag", 3),
    ("c_v_ir", 1),
    ("c_h_ir", 1),
    ("c_v_la", 1),
    ("zupt", 3),
)
#: columns of the residual array
NRES = sum(w for _, w in RESIDUALS)
#: Columns of a step's stored prediction (``work``'s third array): ``Phi_top P`` (10 x 22) and the upper
#: triangle of the predicted covariance's kinematic block (55).
NPRED = 10 * N + 55
#: Longest run [steps] whose predictions are stored for the backward pass (2.2 KB/step of scratch).  On a
#: multi-jump day the scratch is reused from jump to jump and the backward pass skips forming them again
#: (23 jumps, 59k steps: the loop 8.65 -> 7.93 us/step); on one long segment the scratch is fresh memory
#: written and read once and nothing is gained (one 60k-step segment: 0.516 vs 0.517 s, +130 MB), so
#: smooth_inputs keeps them only where the longest segment is at most a third of the session, and at most
#: this long (36 MB).
PRED_MAX_STEPS = 16384
#: Steps of a block of the backward pass (issue 38): where the smoothed covariances are not kept, a run longer
#: than this keeps the forward pass's priors and covariances one block at a time (2.2 KB/step, 9 MB), each
#: block's forward pass run again from a checkpoint of the first (the prior state and covariance at the
#: block's first step, 4 KB): the memory of a long session no longer grows by 2.2 KB/step, for a second
#: forward pass; the same numbers to the bit.
BLOCK_STEPS = 4096
#: items of a checkpoint: the state and the full covariance at the top of a step
NCK = N + N * N


def unpack_many(packed: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
    """Packed covariances (n, 253) -> full (n, k, k) over the state indices ``idx`` (default all 22)."""
    iu = np.triu_indices(N)
    full_idx = np.arange(N) if idx is None else np.asarray(idx)
    pos = np.zeros((N, N), dtype=np.int64)
    pos[iu] = np.arange(NP)
    pos = np.maximum(pos, pos.T)
    return packed[:, pos[np.ix_(full_idx, full_idx)]]


_UNSET = object()
_NATIVE: object = _UNSET


def native() -> ModuleType | None:
    """The C extension module, or None when it is not built or ``SPORTFUSION_NATIVE=0``."""
    global _NATIVE
    if _NATIVE is _UNSET:
        _NATIVE = load_extension("sportfusion.skijump._ski_c")
    return _NATIVE  # type: ignore[return-value]


def _f64(a: object) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _layout(a: np.ndarray, m: int, name: str) -> tuple[np.ndarray, int, int]:
    """An (n, m) output for the C loop: ``(buffer, ld, off)``.  ld 0: ``a`` is C-contiguous (row-major);
    else ``a`` is ``whole[:, off:off + n].T`` of a C-contiguous float64 ``whole`` (m, ld), every column of
    ``a`` a contiguous run of ``whole``'s row (what a table's columns are made of without a copy)."""
    if a.flags.c_contiguous and a.dtype == np.float64:
        return a, 0, 0
    base = a.base
    if (
        a.dtype == np.float64
        and isinstance(base, np.ndarray)
        and base.ndim == 2
        and base.shape[0] == m
        and base.flags.c_contiguous
        and a.strides == (8, 8 * base.shape[1])
    ):
        off = (a.__array_interface__["data"][0] - base.__array_interface__["data"][0]) // 8
        if 0 <= off and off + a.shape[0] <= base.shape[1]:
            return base, base.shape[1], off
    raise ValueError(f"ski_ekf_rts: {name} must be C-contiguous float64 (n, {m}) or columns of an ({m}, ld) array")


def column_outputs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Session-wide smoothed states (n, 22) and std rows (n, NSTD) laid out column by column (each the ``.T``
    of a C-contiguous array): segments' rows of them are valid ``out`` arrays of :func:`ski_ekf_rts`, and a
    state's column is contiguous (an output column of the table without a copy)."""
    return np.empty((N, n)).T, np.empty((NSTD, n)).T


def ski_ekf_rts(
    t, u, pos, vel, mag, inrun, landing, still, x0, P0, g0, mno, m_o, qd, rpos, rvel, rmag, rcq, rir, rhir, rla,
    rzu, ir_x0, ir_step, ir_z, ir_dz, la_x0, la_step, la_z, la_dz, use_hill, use_vel, use_mag, smooth,
    filtered_cov=True, smoothed_cov=True, out=None, work=None,
):  # fmt: skip  # noqa: ANN001, ANN201
    """Forward EKF and (``smooth``) backward RTS over all steps, in C (``_ski_c.c``'s ``run``).

    The arguments are the segment's arrays (``t`` (n,), ``u`` (n, 6), ``pos``, ``vel``, ``mag`` (n, 3) NaN where
    absent, the constraint windows and still weights (n,)), the initial state and covariance, gravity,
    ``M_NO``, the reference field, the input noise per step (n, 6), the measurement variances, the profile
    tables (origin, step, ``z``, ``dz/dx``) and the switches; the model and its numpy reference are
    :mod:`sportfusion.skijump.smoother_engine`'s (the caller).  Returns ``(x_filt, x_smooth, P_packed, resid,
    fail, phase, std)``: the states (n, 22) (``x_smooth`` is ``x_filt`` without ``smooth``), the packed
    covariances (n, 253; the smoothed ones, or the filtered ones without ``smooth``), the innovations (n, NRES)
    in :data:`RESIDUALS`' order (NaN where absent), the step at which a covariance stopped being positive
    definite (-1: none) and in which phase (0 update, 1 prediction, 2 backward pass), and the smoothed
    standard deviations (n, NSTD; (0, NSTD) without ``smooth``).

    ``filtered_cov=False`` with ``smooth=False``: the filtered covariances are not kept (the returned
    packed covariances are an empty (0, 253) array): a forward run for its states alone then writes
    2 KB less per step.  ``smoothed_cov=False`` with ``smooth``: the smoothed covariances are not written
    back (only the ``std`` rows are wanted); the packed covariances returned are then empty too.
    ``out`` (with ``smooth``): ``(x_filt, x_smooth, resid, std)`` arrays of shapes (n, 22), (n, 22),
    (n, NRES), (n, NSTD) to write into (C-contiguous float64, e.g. a segment's rows of the session's arrays:
    no concatenation afterwards; ``x_smooth`` and ``std`` may instead be rows of :func:`column_outputs`'
    column-major arrays); ``resid`` is set to NaN first.  ``x_filt`` None: the filtered states are not kept
    (the returned ones are an empty (0, 22) array; their scratch is ``work``'s fourth array where it has one,
    of at least n rows or, with blocks, ``nb``: 0.2 KB/step less on a long run).  ``work``: ``(x_pred,
    P_packed)`` scratch arrays of at least n rows (22 and 253 columns) reused from run to run (fresh ones would
    have their pages zeroed by the kernel on first touch, ~2 % of a multi-jump day); only where the
    covariances are not returned (``smoothed_cov=False``).  A third array of ``work`` (at least n - 1 rows of
    :data:`NPRED`) keeps each step's prediction from the forward pass for the backward pass (same results, to
    the bit; None: none kept).  Where ``work``'s covariance array has fewer rows than the run (``nb`` of them:
    :func:`sportfusion.skijump.smoother_engine.c_buffers`), the backward pass goes through blocks of ``nb``
    steps, each block's forward pass run again from a checkpoint (``work``'s first array then has ``nb + 1``
    rows, its third ``nb``): the same results, to the bit.
    Raises RuntimeError when the extension is not built (call :func:`native` first).
    """
    mod = native()
    if mod is None:
        raise RuntimeError("the C extension sportfusion.skijump._ski_c is not built")
    n = int(np.asarray(t).size)
    keep = bool(smooth) or bool(filtered_cov)
    pred = ck = None
    nb = 0
    if work is not None and smooth and not smoothed_cov:
        if n > work[1].shape[0]:  # blocks of nb steps
            nb = work[1].shape[0]
            x_pred, pbuf = work[0][: nb + 1], work[1]
            ck = np.empty(((n + nb - 1) // nb, NCK))
            if len(work) > 2 and work[2] is not None:
                pred = work[2][:nb]
        else:
            x_pred, pbuf = work[0][:n], work[1][:n]
            if len(work) > 2 and work[2] is not None and work[2].shape[0] >= n - 1:
                pred = work[2]
    else:
        x_pred = np.empty((n, N) if keep else (1, N))  # the C side checks the sizes only where it writes
        pbuf = np.empty((n, NP) if keep else (1, NP))
    kept_filt = True
    if out is not None and smooth:
        x_filt, x_s, resid, std = out
        resid.fill(np.nan)
        if x_filt is None:  # not kept: scratch for the backward pass, one block of them where it runs in blocks
            kept_filt = False
            rows = nb or n
            has = work is not None and len(work) > 3 and work[3].shape[0] >= rows
            x_filt = work[3][:rows] if has else np.empty((rows, N))  # type: ignore[index]
    else:
        x_filt = np.empty((n, N))
        x_s = np.empty((n, N)) if smooth else x_filt
        resid = np.full((n, NRES), np.nan)
        std = np.empty((n, NSTD)) if smooth else np.empty((0, NSTD))
    rpos, rvel = _f64(rpos), _f64(rvel)
    xs_buf, ldx, offx = _layout(x_s, N, "x_smooth") if smooth else (np.empty((n, N)), 0, 0)
    std_buf, lds, offs = _layout(std, NSTD, "std") if smooth else (np.empty((n, NSTD)), 0, 0)
    par = np.array(
        [g0, *rpos, *rvel, rmag, rcq, rir, rhir, rla, ir_x0, ir_step, la_x0, la_step]
        + [float(bool(v)) for v in (use_hill, use_vel, use_mag, smooth)]
        + [rzu, float(keep), float(bool(smoothed_cov)), ldx, offx, lds, offs],
        dtype=np.float64,
    )
    fail, phase = mod.ekf_rts(
        n,
        *(
            _f64(a)
            for a in (t, u, pos, vel, mag, inrun, landing, still, x0, P0, mno, m_o, qd, ir_z, ir_dz, la_z, la_dz)
        ),
        par,
        x_filt,
        x_pred,
        xs_buf,
        pbuf,
        resid,
        std_buf,
        pred,
        nb,
        ck,
    )
    if not keep or (smooth and not smoothed_cov):
        pbuf = np.empty((0, NP))
    if not kept_filt:
        x_filt = np.empty((0, N))
    if fail >= 0:
        return x_filt, x_filt, pbuf, resid, fail, phase, np.empty((0, NSTD))
    return x_filt, x_s, pbuf, resid, -1, 0, std
