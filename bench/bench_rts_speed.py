"""rts-smooth speed on a 10-minute 100 Hz session (60,000 steps), beside filterpy.

The session: ``simulate skijump`` (Oberstdorf HS106, seed 0) with a long rest
after the jump, so that IMU, GNSS (10 Hz) and magnetometer run for 600 s.

Timed, in this one process:

* ours, the C EKF + RTS loop of the ski model (``_ski_c.c``), one pass
  (like-for-like with filterpy), and ``rts_smooth_table`` end to end with its
  defaults (input preparation, re-linearisation passes, output columns);
* ours, the numpy reference path (``ekf_rts`` with the model callables), on a
  slice, scaled to 60,000 steps;
* filterpy 1.4 ``ExtendedKalmanFilter`` (predict with our RK4 ``predict_x``, F
  and Q from our discretisation; update with our stacked measurements and
  Jacobians, Joseph form) + ``KalmanFilter.rts_smoother``, on a slice, scaled
  to 60,000 steps (filterpy's smoother predicts the mean linearly, F x, where
  ours uses the RK4 prediction of the forward pass).

Memory: our loop stores per step three state vectors, the packed smoothed
covariance and the innovations (``bytes/step`` below): it grows linearly.

Run: ``python bench/bench_rts_speed.py [--quick] [--slice 3000]``.
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time

import numpy as np

TARGET_S = 2.0
TARGET_RATIO = 20.0


def build(rest_after: float):  # noqa: ANN201
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump
    from sportfusion.skijump.smoother_inputs import SmootherConfig, session_inputs

    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(hill, SkiJumpConfig(seed=0, rest_after=rest_after))
    tt = sim.truth_meta["skijump"]["times"]
    cfg = SmootherConfig(passes=1, pass_window=math.inf)  # one pass over the whole session, nothing else
    inp, _ = session_inputs(sim.session, sim.session_meta, hill, cfg, [tt["takeoff"]], [tt["touchdown"]])
    return hill, sim, inp, cfg, tt


def time_filterpy(inp, hill, cfg, n: int) -> float:  # noqa: ANN001
    """filterpy EKF + RTS over the first n steps of the same model [s]."""
    from filterpy.kalman import ExtendedKalmanFilter, KalmanFilter

    from sportfusion.skijump import model as mdl
    from sportfusion.skijump.kinematics import m_no
    from sportfusion.skijump.smoother_inputs import ProfileTable, _slice
    from sportfusion.skijump.smoother_start import initial_state

    seg = _slice(inp, 0, n)
    x0, P0 = initial_state(seg, cfg)
    mno = m_no(math.radians(seg.azimuth_deg))
    qd = np.array([cfg.q_gyr] * 3 + [cfg.q_acc] * 3) ** 2
    ir, la = ProfileTable(hill, "inrun"), ProfileTable(hill, "landing")
    Rd = {
        "pos": np.asarray(cfg.r_gnss_pos) ** 2,
        "vel": np.asarray(cfg.r_gnss_vel) ** 2,
        "mag": np.full(3, cfg.r_mag**2),
    }

    class EKF(ExtendedKalmanFilter):
        k = 0

        def predict_x(self, u=0):  # noqa: ANN001, ANN202
            k = self.k
            self.x = mdl.rk4_aug(self.x, seg.u[k], seg.u[k + 1], seg.t[k + 1] - seg.t[k], seg.g0, mno)

    ekf = EKF(dim_x=mdl.N, dim_z=13)
    ekf.x = x0.copy()
    ekf.P = P0.copy()
    Xs, Ps = np.zeros((n, mdl.N)), np.zeros((n, mdl.N, mdl.N))
    Fs, Qs = np.zeros((n, mdl.N, mdl.N)), np.zeros((n, mdl.N, mdl.N))
    t0 = time.perf_counter()
    for k in range(n):
        x = ekf.x
        blocks = []  # (z, h(x), H, R diag)
        blocks.append((np.zeros(1), np.array([mdl.c_q(x)]), mdl.C_q(x), np.array([cfg.r_c_q**2])))
        if np.isfinite(seg.pos[k, 0]):
            H = np.zeros((3, mdl.N))
            H[:, 0:3] = np.eye(3)
            blocks.append((seg.pos[k], x[0:3], H, Rd["pos"]))
        if np.isfinite(seg.vel[k, 0]):
            blocks.append((seg.vel[k], mdl.h_vel(x), mdl.H_vel(x), Rd["vel"]))
        if np.isfinite(seg.mag[k, 0]):
            blocks.append((seg.mag[k], mdl.h_mag(x, seg.m_o), mdl.H_mag(x, seg.m_o), Rd["mag"]))
        if seg.inrun[k]:
            z, dz = ir(x[0])
            H = np.zeros((2, mdl.N))
            H[0, 0], H[0, 2], H[1, 1] = -dz, 1.0, 1.0
            blocks.append((np.zeros(2), np.array([x[2] - z, x[1]]), H, np.array([cfg.r_c_v_ir**2, cfg.r_c_h_ir**2])))
        if seg.landing[k] > 0:
            z, dz = la(x[0])
            H = np.zeros((1, mdl.N))
            H[0, 0], H[0, 2] = -dz, 1.0
            blocks.append((np.zeros(1), np.array([x[2] - z]), H, np.array([cfg.r_c_v_la**2 / seg.landing[k]])))
        if seg.still is not None and seg.still[k] > 0:  # zero-velocity update
            H = np.zeros((3, mdl.N))
            H[:, 3:6] = np.eye(3)
            blocks.append((np.zeros(3), x[3:6], H, np.full(3, cfg.r_zupt**2 / seg.still[k])))
        zz = np.concatenate([b[0] for b in blocks])
        hx = np.concatenate([b[1] for b in blocks])
        HH = np.vstack([b[2] for b in blocks])
        RR = np.diag(np.concatenate([b[3] for b in blocks]))
        ekf.update(zz, lambda _x, H=HH: H, lambda _x, h=hx: h, R=RR)
        Xs[k], Ps[k] = ekf.x, ekf.P
        if k < n - 1:
            ekf.k = k
            Phi, Qd = mdl.discrete(
                mdl.jac_a(ekf.x, seg.u[k], seg.g0, mno), mdl.jac_f(ekf.x), qd, seg.t[k + 1] - seg.t[k]
            )
            ekf.F, ekf.Q = Phi, Qd
            Fs[k + 1], Qs[k + 1] = Phi, Qd
            ekf.predict()
    KalmanFilter(dim_x=mdl.N, dim_z=1).rts_smoother(Xs, Ps, Fs, Qs)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2-minute session, filterpy on 1000 steps")
    ap.add_argument("--slice", type=int, default=3000, help="steps timed for filterpy and the numpy path")
    a = ap.parse_args()
    rest = 98.0 if a.quick else 578.0
    sl = 1000 if a.quick else a.slice
    t0 = time.perf_counter()
    hill, sim, inp, cfg, tt = build(rest)
    n = inp.t.size
    print(f"session: {n} IMU steps ({inp.t[-1] - inp.t[0]:.0f} s at 100 Hz), built in {time.perf_counter() - t0:.1f} s")
    from sportfusion.skijump import smoother as R
    from sportfusion.skijump import smoother_inputs as RI
    from sportfusion.skijump.smoother_engine import compiled
    from sportfusion.skijump.smoother_passes import smooth_inputs

    if not compiled():
        print("the C extension sportfusion.skijump._ski_c is not built: only the numpy path can be timed")
        return
    runs, cpu = [], []
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        smooth_inputs(inp, cfg, engine="c")
        runs.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    ours, ours_cpu = min(runs), min(cpu)
    t0 = time.perf_counter()
    R.rts_smooth_table(sim.session, sim.session_meta, hill, takeoff=[tt["takeoff"]], touchdown=[tt["touchdown"]])
    table_s = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    smooth_inputs(RI._slice(inp, 0, sl), cfg, engine="numpy")
    numpy_s, numpy_cpu = (time.perf_counter() - t0) * n / sl, (time.process_time() - c0) * n / sl
    try:
        c0 = time.process_time()
        fp = time_filterpy(inp, hill, cfg, sl) * n / sl
        fp_cpu = (time.process_time() - c0) * n / sl
    except ImportError:
        fp = fp_cpu = float("nan")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    per_step = (3 * 22 + 253 + 13 + 28) * 8  # x_filt, x_pred, x_smooth, packed P, residuals, std rows
    print(f"{'':44}{'time [s]':>10}{'us/step':>10}")
    rows = [
        ("ours, C EKF+RTS, one pass (best of 3)", ours),
        ("ours, rts_smooth_table end to end (defaults)", table_s),
        (f"ours, numpy reference path (x{n / sl:.0f} of {sl})", numpy_s),
        (f"filterpy EKF + rts_smoother (x{n / sl:.0f} of {sl})", fp),
    ]
    for label, s in rows:
        print(f"{label:44}{s:10.2f}{s / n * 1e6:10.1f}")
    print(f"numpy reference / C (one pass): x{numpy_s / ours:.0f} wall, x{numpy_cpu / ours_cpu:.0f} CPU "
          "(the path that runs where the extension is not built)")  # fmt: skip
    print(f"filterpy / ours (C, one pass): {fp / ours:.0f}x wall, {fp_cpu / ours_cpu:.0f}x CPU "
          f"(target >= {TARGET_RATIO:.0f}x); ours {ours:.2f} s wall, {ours_cpu:.2f} s CPU time "
          f"(target < {TARGET_S:.0f} s on one core; CPU time excludes waiting for a core)")  # fmt: skip
    print(f"memory: {per_step} bytes/step stored ({per_step * n / 1e6:.0f} MB for {n} steps, linear); "
          f"peak RSS of this process {peak:.0f} MB")  # fmt: skip
    print("timings on a shared 2-core machine: noisy, compare ratios")


if __name__ == "__main__":
    sys.exit(main())
