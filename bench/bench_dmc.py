"""Benchmark dmc-attitude's batched QUEST against the ``ahrs`` package, plus its accuracy on simulated runs.

Prints, in one process:
1. time per sample of the batched QUEST (1e6 samples) and of Davenport's
   eigen-decomposition (numpy ``eigh``), against ``ahrs.filters.QUEST`` per
   sample, with the largest attitude difference [deg] on the common samples;
2. the attitude error against the simulator's truth in low dynamics (standing
   start, f = -g) and high dynamics (the run, f from the GNSS spline), of the
   DMC alone (per sample, the paper's method) and gyro-stabilised (the
   simulator's MEMS gyro fused over the run, ``dmc-attitude``'s default when
   ``gyr_*`` are present), beside the paper's statement ("several degrees" in
   high dynamics) and the DMC-alone figure before the gyro (issue 19), and the
   gyro path before the sensor biases were estimated (``sigma_mag_bias`` and
   ``sigma_acc_bias`` 0, computed in this run) beside the default (the
   magnetometer's hard iron and the accelerometer's bias estimated along).
   Bench seeds 1-5; the gyro path's defaults were chosen on seeds 11-30.

Peers (``pip install ahrs``) that are missing are reported and skipped.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from sportfusion.core.rotations import quat_angle, quat_normalize, to_body
from sportfusion.core.schema import floats
from sportfusion.estimators.quest import davenport, quest
from sportfusion.skirace.attitude import dmc_attitude, reference_specific_force
from sportfusion.skirace.dmc import dmc_session
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace
from sportfusion.skirace.track import smooth_track

N = 1_000_000
N_AHRS = 3000


def speed() -> None:
    rng = np.random.default_rng(0)
    q = quat_normalize(rng.standard_normal((N, 4)))
    ref = np.array([[0.0, 0.0, 1.0], [21.46, 1.48, 43.44]])
    ref_unit = ref / np.linalg.norm(ref, axis=1, keepdims=True)
    body = np.stack([to_body(q, r) for r in ref_unit], axis=1) + 0.01 * rng.standard_normal((N, 2, 3))
    w = np.array([0.5, 0.5])
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        qq, _ = quest(body, ref, w)
        times.append(time.perf_counter() - t0)
    ours = min(times) / N
    # the whole per-sample work of dmc-attitude: QUEST + Euler angles + singular flags + re-estimated acceleration
    a_ned = rng.normal(0.0, 5.0, (N, 3))
    f_ref = reference_specific_force(a_ned, 9.81)
    m_ref = ref[1]
    f_b, m_b = to_body(q, f_ref), to_body(q, np.broadcast_to(m_ref, (N, 3)))
    full = []
    for _ in range(3):
        t0 = time.perf_counter()
        dmc_attitude(f_b, m_b, f_ref, m_ref, 9.81)
        full.append(time.perf_counter() - t0)
    full_us = min(full) / N
    t0 = time.perf_counter()
    qd, _ = davenport(body[:200_000], ref, w)
    dav = (time.perf_counter() - t0) / 200_000
    print(f"== speed: batched QUEST on {N:,} samples (two vectors: specific force, magnetic field)")
    print(f"  {'method':<34} {'[us/sample]':>12} {'x ours':>8} {'max diff [deg]':>15}  reference")
    print(f"  {'sportfusion QUEST (compiled)   ':<34} {ours * 1e6:12.3f} {1.0:8.1f} {0.0:15.1e}  0.36 us (DESIGN)")
    print(f"  {'sportfusion dmc_attitude (all out)':<34} {full_us * 1e6:12.3f} {full_us / ours:8.1f} {'':>15}")
    d = np.degrees(np.max(quat_angle(qq[:200_000], qd)))
    print(f"  {'Davenport q-method (numpy eigh)':<34} {dav * 1e6:12.3f} {dav / ours:8.1f} {d:15.1e}")
    try:
        from ahrs.filters import QUEST

        acc, mag = body[:N_AHRS, 0], body[:N_AHRS, 1]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            Q = QUEST(acc=acc, mag=mag, magnetic_dip=ref_unit[1], weights=w).Q
            peer = (time.perf_counter() - t0) / N_AHRS
        d = np.degrees(np.max(quat_angle(qq[:N_AHRS], Q)))
        print(
            f"  {'ahrs.filters.QUEST (per sample)':<34} {peer * 1e6:12.3f} {peer / ours:8.1f} {d:15.1e}  81 us (DESIGN)"
        )
        print(
            f"  (required: >= 100x faster than ahrs, same answers to 1e-6 deg; on {N_AHRS} samples): QUEST "
            f"{peer / ours:.0f}x, the whole dmc_attitude (QUEST + Euler + flags + acceleration) {peer / full_us:.0f}x"
        )
    except ImportError:
        print("  ahrs is not installed (pip install ahrs): row skipped")


def accuracy() -> None:
    print("== attitude error against the simulator's truth (median; p90: 90th percentile) [deg]")
    print(
        "  gyro: sensor biases estimated (the default); no bias: gyro path with --mag-bias-sigma 0 --acc-bias-sigma 0"
    )
    print(
        f"  {'':4} {'low dynamics':>26} {'high dynamics, DMC alone':>25} {'high dynamics, gyro+DMC':>41}"
        f" {'a_dmc err [m/s^2]':>18}"
    )
    print(
        f"  {'seed':>4} {'DMC':>8} {'no bias':>8} {'gyro':>8} {'median':>12} {'p90':>12} {'no bias':>9} {'median':>10}"
        f" {'p90':>9} {'all rows':>10} {'DMC':>8} {'gyro':>9}"
    )
    highs, dmc_highs, lows, lows0, highs0 = [], [], [], [], []
    off = {"sigma_mag_bias": 0.0, "sigma_acc_bias": 0.0}
    for seed in range(1, 6):
        s = simulate_skirace(SkiRaceConfig(seed=seed))
        T, tr, meta = s.session, s.truth, s.meta

        def cols(names, table=T):
            return np.column_stack([floats(table, n) for n in names])

        t = floats(T, "t")
        az = meta["frame"]["azimuth_deg"]
        site = tuple(meta["frame"]["origin"])
        when = meta["time"]["epoch_utc"]
        acc, mag = cols(["acc_x", "acc_y", "acc_z"]), cols(["mag_x", "mag_y", "mag_z"])
        gyr = cols(["gyr_x", "gyr_y", "gyr_z"])
        kw = {"azimuth_deg": az, "site": site, "when": when}
        sig = cols(["std_gnss_x", "std_gnss_y", "std_gnss_z"])
        trk = smooth_track(t, cols(["gnss_x", "gnss_y", "gnss_z"]), floats(T, "gnss_fix"), sig, azimuth_deg=az, lam=0.9)
        a_kin = np.column_stack([trk.columns[f"a{c}"] for c in "xyz"])
        qt = cols([f"true_q{i}" for i in range(4)], tr)
        a_true = cols(["true_ax", "true_ay", "true_az"], tr)

        def err(res, qt=qt, a_true=a_true):
            q = np.column_stack([res.columns[f"q{i}"] for i in range(4)])[res.rows]
            a = np.column_stack([res.columns[f"a{c}_dmc"] for c in "xyz"])[res.rows]
            return np.degrees(quat_angle(q, qt[res.rows])), np.linalg.norm(a - a_true[res.rows], axis=1)

        low, _ = err(dmc_session(t, acc, mag, **kw))
        low_g, _ = err(dmc_session(t, acc, mag, gyr=gyr, **kw))
        low_g0, _ = err(dmc_session(t, acc, mag, gyr=gyr, **off, **kw))
        fused0, _ = err(dmc_session(t, acc, mag, acc_kin=a_kin, gyr=gyr, **off, **kw))
        high_res = dmc_session(t, acc, mag, acc_kin=a_kin, **kw)
        high, a_err = err(high_res)
        fused, a_err_g = err(dmc_session(t, acc, mag, acc_kin=a_kin, gyr=gyr, **kw))
        rows = high_res.rows
        static = t[rows] < 5.0
        sing = high_res.columns["dmc_singular"].to_numpy(zero_copy_only=False)[rows].astype(bool)
        run = (t[rows] > 6.0) & ~sing  # the DMC's usable rows (free fall and singular geometry left out)
        highs.append(np.median(fused[run]))
        dmc_highs.append(np.median(high[run]))
        lows.append(np.median(low_g[static]))
        lows0.append(np.median(low_g0[static]))
        highs0.append(np.median(fused0[run]))
        print(
            f"  {seed:4d} {np.median(low[static]):8.2f} {lows0[-1]:8.2f} {np.median(low_g[static]):8.2f}"
            f" {np.median(high[run]):12.2f} {np.percentile(high[run], 90):12.2f}"
            f" {highs0[-1]:9.2f} {np.median(fused[run]):10.2f} {np.percentile(fused[run], 90):9.2f} {np.median(fused[t[rows] > 6.0]):10.2f}"
            f" {np.median(a_err[run]):8.2f} {np.median(a_err_g[run]):9.2f}"
        )
    print(
        "  required: low dynamics < 1 deg (gyro): "
        f"{'met' if max(lows) < 1.0 else 'NOT met'} on {sum(v < 1.0 for v in lows)} of {len(lows)} seeds "
        f"(worst {max(lows):.2f} deg); high dynamics (gyro+DMC) median <= 1.5 deg on every seed: "
        f"{'met' if max(highs) <= 1.5 else 'NOT met'} (worst {max(highs):.2f} deg)"
    )
    print(
        f"  before the sensor biases (issue 19, this run's 'no bias' columns): low dynamics {min(lows0):.2f}-"
        f"{max(lows0):.2f} deg ({sum(v < 1.0 for v in lows0)} of {len(lows0)} below 1 deg), high dynamics "
        f"{min(highs0):.2f}-{max(highs0):.2f} deg; with them {min(lows):.2f}-{max(lows):.2f} and "
        f"{min(highs):.2f}-{max(highs):.2f} deg"
    )
    print(
        "  paper: the DMC/GPS attitude in high dynamics 'may be several degrees lower than what is expected in low "
        "dynamic' (1 deg); 'gyro-stabilized magnetometers may be a better choice'"
    )
    print(
        f"  before the gyro (issue 19): the DMC alone, {min(dmc_highs):.2f}-{max(dmc_highs):.2f} deg high-dynamics "
        "median on these seeds (the DMC-alone column above, this run)"
    )
    print("  'all rows': the run including the DMC's singular rows (free fall over the jumps), which the gyro bridges")


if __name__ == "__main__":
    speed()
    accuracy()
