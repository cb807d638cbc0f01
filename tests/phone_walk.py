"""A phone carried on a walk, written as a Sensor Logger export with the phone's own fused attitude.

An independent generator for the dmc-attitude tests (issue 36, item 2): it knows nothing of the estimators.
The phone is held in front of the walker (screen tilted 40 deg towards them), bobbing with the steps (2 Hz),
turning at corners; its sensors as Android writes them (TotalAcceleration: specific force with gravity,
Gyroscope: the instantaneous rate with a bias, Magnetometer: the field plus a hard iron, all in uT or SI) and
``Orientation.csv``: the phone's fused attitude, Android's rotation vector (device -> east-north-up) with
qx qy qz qw, here the truth plus a 1 deg error, as a phone's own fusion is good to about that.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

#: the Earth's field in NED [uT] (a mid-latitude site, dip ~63 deg)
FIELD_NED = np.array([21.5, 0.5, 43.0])
G = 9.80665
ENU_FROM_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def heading(t: np.ndarray) -> np.ndarray:
    """Heading [rad] clockwise from north: north, a right turn to east at 12 s, back north at 26 s, sway."""
    turn = np.clip((t - 12.0) / 2.0, 0, 1) * np.pi / 2 - np.clip((t - 26.0) / 2.0, 0, 1) * np.pi / 2
    return turn + np.radians(4.0) * np.sin(2 * np.pi * 1.0 * t)


def attitude(t: np.ndarray) -> Rotation:
    """R_ENU<-B: phone flat (x east, y north, z up), its top raised by 40 deg +- bobbing, then the heading."""
    pitch = np.radians(40.0 + 3.0 * np.sin(2 * np.pi * 2.0 * t))
    roll = np.radians(2.5 * np.sin(2 * np.pi * 1.0 * t + 0.3))
    tilt = Rotation.from_euler("xy", np.column_stack([pitch, roll]))  # about body x (top up), then body y
    return Rotation.from_euler("z", -heading(t)[:, None]) * tilt


def walk(duration: float = 40.0, rate: float = 100.0, seed: int = 0, hard_iron=(3.0, -2.0, 1.5)):
    """Sensor samples and the true attitude at ``rate`` [Hz]; returns a dict of arrays (times in s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / rate)
    r = attitude(t)
    h = 1e-4  # the instantaneous body rate, from the rotation over +-h/2
    w = (attitude(t - h / 2).inv() * attitude(t + h / 2)).as_rotvec() / h
    psi = heading(t)
    step = 2 * np.pi * 2.0 * t
    a_enu = np.column_stack(
        [0.6 * np.sin(step + 0.5) * np.sin(psi), 0.6 * np.sin(step + 0.5) * np.cos(psi), 1.5 * np.sin(step)]
    )
    f_b = r.inv().apply(a_enu + [0.0, 0.0, G])  # specific force (Android: with gravity, +z up when flat)
    m_b = r.inv().apply(ENU_FROM_NED @ FIELD_NED) + np.asarray(hard_iron)
    gyr = w + [0.012, -0.006, 0.009]
    f_b += rng.normal(0, 0.05, f_b.shape)
    m_b += rng.normal(0, 0.4, m_b.shape)
    gyr += rng.normal(0, 0.003, gyr.shape)
    fused = r * Rotation.from_rotvec(rng.normal(0, np.radians(1.0) / np.sqrt(3), (t.size, 3)))
    return {"t": t, "acc": f_b, "gyr": gyr, "mag": m_b, "true": r, "fused": fused}


def write_export(folder: Path, sim: dict, t0_ns: int = 1_700_000_000_000_000_000) -> Path:
    """The walk as an Android Sensor Logger export folder (Metadata, TotalAcceleration, Gyroscope,
    Magnetometer, Orientation)."""
    folder.mkdir(parents=True, exist_ok=True)
    ns = t0_ns + np.round(sim["t"] * 1e9).astype(np.int64)

    def rows(v: np.ndarray) -> str:
        return "".join(
            f"{n},{(n - t0_ns) * 1e-9:.9f}," + ",".join(f"{x:.6f}" for x in r) + "\n"
            for n, r in zip(ns, v, strict=True)
        )

    (folder / "Metadata.csv").write_text(
        "version,device name,recording time,platform,appVersion\n3,Pixel,2023-11-14_22-13-20,android,1.30.0\n"
    )
    for name, key in (("TotalAcceleration", "acc"), ("Gyroscope", "gyr"), ("Magnetometer", "mag")):
        (folder / f"{name}.csv").write_text("time,seconds_elapsed,z,y,x\n" + rows(sim[key][:, ::-1]))
    q = sim["fused"].as_quat()  # x y z w
    (folder / "Orientation.csv").write_text("time,seconds_elapsed,qz,qy,qx,qw\n" + rows(q[:, [2, 1, 0, 3]]))
    return folder


def read_orientation(folder: Path) -> tuple[np.ndarray, Rotation]:
    """The export's Orientation.csv as (seconds_elapsed, R_BO = NED -> body) for comparison with q_BO."""
    data = np.loadtxt(folder / "Orientation.csv", delimiter=",", skiprows=1)
    r_enu_b = Rotation.from_quat(data[:, [4, 3, 2, 5]])  # x y z w
    r_bo = r_enu_b.inv() * Rotation.from_matrix(ENU_FROM_NED)  # body <- ENU <- NED
    return data[:, 1], r_bo
