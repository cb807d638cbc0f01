"""``simulate skijump`` with the full physics of :mod:`sportfusion.skijump.sim.sensors` (``physics="full"``).

The jump (the same motion as the paper mode for a seed: in-run, take-off, flight, landing, out-run) is
computed on the 1 kHz grid; vibration is added to it; the chips sense it (:func:`sportfusion.sim.imu.sense`)
and output 100 Hz samples at a random phase of the IMU clock; the GNSS receiver fixes its helmet antenna at
whole tenths of a second.  The session's rows are the union of the IMU's and the receiver's instants, as a
real recording's; the truth has a row at each of them (the fine-grid sample there, no interpolation).

Nothing here knows the smoother: the truth is the motion itself, sampled, never re-integrated.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import rotations, schema
from sportfusion.sim.imu import TriadErrors, sense
from sportfusion.skijump.sim.attitude import arm_motion, attitude, mounting
from sportfusion.skijump.sim.motion import JumpMotion
from sportfusion.skijump.sim.sensors import (
    Realism,
    angular_vibration,
    antenna_state,
    dipole_sum,
    gnss_errors,
    imu_errors,
    stream,
    table_dipoles,
    temperature,
    translational_vibration,
)
from sportfusion.skijump.sim.venue import SimHill

IMU_RATE = 100.0  # [Hz]
GNSS_RATE = 10.0  # [Hz]


def _col(name: str, values: np.ndarray) -> pa.Array:
    return schema.to_arrow(name, np.ascontiguousarray(values))


def simulate_full(
    hill: SimHill,
    seed: int,
    rng: np.random.Generator,
    motion: JumpMotion,
    field_o: np.ndarray,
    r: Realism,
    outages: list[tuple[float, float]] | None = None,
    body_lever: tuple[float, float, float] | None = None,
    noise: bool = True,
) -> dict[str, Any]:
    """Run ``motion`` on the fine grid and sense it (module text).

    Parameters
    ----------
    hill : the hill (frame, profile, gravity)
    seed : the simulation's seed (the effects' random streams)
    rng : the main generator, after the motion's draws (the arm's posture and the mounting come next)
    motion : the planned jump
    field_o : Earth's field at the site (World Magnetic Model or the hill file's) [uT], NED
    r : the physics
    outages : GNSS outages (start, end) [s]
    body_lever : an antenna fixed to the phone instead of the helmet: IMU -> antenna in the phone's frame [m]
    noise : False: sensors without errors (the antialiasing filter and the sampling stay)

    Returns
    -------
    dict with ``session``, ``truth`` (pyarrow tables), ``times``, ``figures``, ``meta`` (truth metadata
    extras), ``raw`` (what ``write_raw`` needs), ``mounting``, ``motion`` (MotionTruth on the fine grid).
    """
    frame = hill.frame
    az = frame.azimuth_deg
    g = hill.g
    fs = r.fine_rate
    dec = int(round(fs / IMU_RATE))
    motion.p.dt = 1.0 / fs
    motion.p.match_jerk = False  # an impact is a kink at 1 kHz (and the jerk's differences are release-sensitive)
    mt = motion.run()
    arm = arm_motion(mt.times, rng)
    m_ba = mounting(rng)
    t = mt.t
    n = t.size
    vib = stream(seed, "vibration")
    d, dv, da = translational_vibration(t, mt.a, mt.times, r, vib)
    r_imu, v_imu, a_imu = mt.r + d, mt.v + dv, mt.a + da
    angular_vibration(arm, mt.times, r, vib)
    q, w_b, m_jo, w_jo = attitude(
        t, math.radians(az), mt.pitch, mt.pitch_rate, mt.heading, mt.heading_rate, arm, m_ba, jumper=True
    )
    acc_true = rotations.to_body(q, rotations.local_to_ned(a_imu - np.array([0.0, 0.0, g]), az))
    # magnetic field at the phone: Earth (model + site anomaly) and the table's steel
    mr = stream(seed, "mag")
    anomaly = mr.normal(0.0, r.mag_anomaly, 3)
    dip = table_dipoles(mr, r, hill.z_inrun)
    field_total = field_o + anomaly + rotations.local_to_ned(dipole_sum(r_imu, dip), az)
    mag_true = rotations.to_body(q, field_total)
    mag_err = TriadErrors(
        bias=mr.normal(0.0, r.mag_bias, 3),
        scale=mr.normal(0.0, r.mag_scale, 3),
        misalign=mr.normal(0.0, r.mag_cross, (3, 3)),
        noise_density=r.mag_noise / math.sqrt(fs / 2.0),
        lsb=r.mag_lsb,
    )
    acc_err, gyr_err = imu_errors(stream(seed, "imu"), r)
    temp = temperature(t, r, stream(seed, "temperature"))
    gr = stream(seed, "gnss")
    phase = int(gr.integers(1, dec)) if r.off_grid else 0  # the IMU clock's phase against GNSS time [fine steps]
    if not noise:
        acc_err, gyr_err, mag_err = TriadErrors(), TriadErrors(), TriadErrors()
    nz = stream(seed, "noise")
    k_imu = np.arange(phase, n, dec)
    sl = slice(phase, None)
    gyr = sense(w_b[sl], fs, dec, gyr_err, nz, temp[sl], r.antialias, r.cutoff, other=acc_true[sl])
    acc = sense(acc_true[sl], fs, dec, acc_err, nz, temp[sl], r.antialias, r.cutoff)
    mag = sense(mag_true[sl], fs, dec, mag_err, nz, None, "point")
    # GNSS: the antenna at whole tenths of GNSS time, describing t - latency
    if body_lever is not None:
        lever = np.broadcast_to(np.asarray(body_lever, dtype=float), (n, 3))
        r_ant = r_imu + rotations.ned_to_local(rotations.to_ned(q, lever), az)
        v_ant = rotations.local_to_ned(v_imu, az) + rotations.to_ned(q, np.cross(w_b, lever))
    else:
        r_ant, v_ant = antenna_state(t, r_imu, v_imu, m_jo, w_jo, az, r, stream(seed, "antenna"))
    every = int(round(fs / GNSS_RATE))
    k_gnss = np.arange(0, n, every) if r.off_grid else k_imu[:: int(round(IMU_RATE / GNSS_RATE))]
    lag = int(round(r.latency * fs))
    src = np.maximum(k_gnss - lag, 0)
    ge = gnss_errors(t[k_gnss], r, gr)
    if not noise:
        ge = {k: np.zeros_like(v) for k, v in ge.items()}
    pos = r_ant[src] + ge["pos"]
    vel = v_ant[src] + ge["vel"]
    keep = np.ones(k_gnss.size, bool)
    for t0, t1 in outages or []:
        keep &= ~((t[k_gnss] >= t0) & (t[k_gnss] <= t1))
    k_gnss, pos, vel = k_gnss[keep], pos[keep], vel[keep]
    lat, lon, h = frame.to_geodetic(pos[:, 0], pos[:, 1], pos[:, 2])
    rows = np.union1d(k_imu, k_gnss)
    i_imu = np.searchsorted(rows, k_imu)
    i_gnss = np.searchsorted(rows, k_gnss)
    tr = rows / fs
    session = _session(tr, i_imu, gyr, acc, mag, i_gnss, lat, lon, h, vel, r)
    bias_acc = acc_err.bias + temp[:, None] * acc_err.temp_coeff
    bias_gyr = gyr_err.bias + temp[:, None] * gyr_err.temp_coeff
    truth = _truth(
        mt,
        rows,
        fs,
        r_imu,
        v_imu,
        a_imu,
        q,
        w_b,
        acc_true,
        mag_true,
        rotations.local_to_ned(v_imu, az),
        az,
        {
            "bias_acc": bias_acc[rows],
            "bias_gyr": bias_gyr[rows],
            "bias_mag": np.broadcast_to(mag_err.bias, (rows.size, 3)),
            "scale_mag": np.broadcast_to(mag_err.scale, (rows.size, 3)),
        },
        r_ant[rows],
    )
    meta = {
        "imu_phase_s": phase / fs,
        "gnss_latency_s": lag / fs,
        "sensor_errors": {
            "bias_acc": acc_err.bias.tolist(),
            "scale_acc": acc_err.scale.tolist(),
            "bias_gyr": gyr_err.bias.tolist(),
            "scale_gyr": gyr_err.scale.tolist(),
            "bias_mag": mag_err.bias.tolist(),
            "scale_mag": mag_err.scale.tolist(),
            "temperature_change_K": float(temp[-1]),
        },
        "mag_anomaly_ned": anomaly.tolist(),
        "table_dipoles": [{"position": p.tolist(), "moment": m.tolist()} for p, m in dip],
        "gnss_outliers": int(np.count_nonzero(np.linalg.norm(ge["outliers"], axis=1))),
    }
    raw = {"t": t[k_imu], "gyr": gyr, "acc": acc, "mag": mag, "t_gnss": t[k_gnss]}
    raw.update(lat=lat, lon=lon, h=h, vel=vel, sigma_pos=(r.sigma_report[0], r.sigma_report[0], r.sigma_report[1]))
    return {
        "session": session,
        "truth": truth,
        "times": mt.times,
        "figures": mt.figures,
        "meta": meta,
        "raw": raw,
        "mounting": m_ba,
    }


def _session(t, i_imu, gyr, acc, mag, i_gnss, lat, lon, h, vel, r: Realism) -> pa.Table:  # noqa: ANN001
    n = t.size
    cols: dict[str, pa.Array] = {"t": pa.array(t, pa.float64())}

    def at(idx: np.ndarray, values: np.ndarray) -> np.ndarray:
        out = np.full(n, np.nan)
        out[idx] = values
        return out

    for name, data in (("acc", acc), ("gyr", gyr), ("mag", mag)):
        for k, ax in enumerate("xyz"):
            cols[f"{name}_{ax}"] = _col(f"{name}_{ax}", at(i_imu, data[:, k]))
    for name, values in (("lat", lat), ("lon", lon), ("h", h)):
        cols[name] = _col(name, at(i_gnss, values))
    for k, name in enumerate(("vel_n", "vel_e", "vel_d")):
        cols[name] = _col(name, at(i_gnss, vel[:, k]))
    mask = np.ones(n, bool)
    mask[i_gnss] = False
    cols["gnss_fix"] = schema.numeric_array(np.ones(n, np.int16), mask)
    cols["gnss_sats"] = schema.numeric_array(np.full(n, 9, np.int16), mask)
    cols["gnss_sigma_h"] = _col("gnss_sigma_h", at(i_gnss, np.full(i_gnss.size, r.sigma_report[0])))
    cols["gnss_sigma_v"] = _col("gnss_sigma_v", at(i_gnss, np.full(i_gnss.size, r.sigma_report[1])))
    return pa.table(cols)


def _truth(mt, rows, fs, r, v, a, q, w_b, acc, mag, v_o, az, errs, r_ant) -> pa.Table:  # noqa: ANN001
    cols: dict[str, Any] = {"t": pa.array(rows / fs, pa.float64())}
    blocks = {
        ("x", "y", "z"): r[rows],
        ("vx", "vy", "vz"): v[rows],
        ("vel_n", "vel_e", "vel_d"): v_o[rows],
        ("ax", "ay", "az"): a[rows],
        ("q0", "q1", "q2", "q3"): q[rows],
        ("acc_x", "acc_y", "acc_z"): acc[rows],
        ("gyr_x", "gyr_y", "gyr_z"): w_b[rows],
        ("mag_x", "mag_y", "mag_z"): mag[rows],
        ("gnss_x", "gnss_y", "gnss_z"): r_ant,
    }
    roll, pitch, yaw = rotations.euler_from_quat(q[rows])
    blocks[("roll", "pitch", "yaw")] = np.stack((roll, pitch, yaw), -1)
    for key, vals in errs.items():
        blocks[tuple(f"{key}_{c}" for c in "xyz")] = vals
    for names, data in blocks.items():
        for k, name in enumerate(names):
            cols[f"true_{name}"] = _col(f"true_{name}", data[:, k])
    cols["true_clearance"] = _col("true_clearance", mt.clearance[rows])
    event = [None] * rows.size
    tr = rows / fs
    for name in ("takeoff", "touchdown"):
        event[int(np.argmin(np.abs(tr - mt.times[name])))] = name
    cols["event"] = pa.array(event, pa.string())
    return pa.table(cols)
