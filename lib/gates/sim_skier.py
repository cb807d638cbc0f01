"""A full-body skier for ``simulate gates --body``: posture that follows the turns, seven strapped IMUs.

Written independently of the estimator (:mod:`sportfusion.body`, which this module never imports): another
anthropometric table (Dempster's, as adapted by Winter 2009, *Biomechanics and Motor Control of Human
Movement*, Table 4.1: segment masses and CoM locations as fractions, segment lengths as fractions of the
height), another segment geometry and another way to build the kinematics (legs by two-link inverse
kinematics from skis placed on the snow, not by rotating segments down a chain).

Kinematics (course frame of :mod:`sportfusion.gates.sim`: x along the fall line, y right, z down):

* the lumbar joint centre (LJC) runs above the snow path of the gates simulator (its snow projection), at a
  height set by the legs' flexion (``k``: hip-ankle distance over the leg length, 0.99 upright, about
  0.74-0.86 while skiing, lowest across the transitions) and the lean ``phi`` (the inclination that balances
  the lateral acceleration, from the gates simulator);
* pelvis, torso and head: heading of travel with counter-rotation to the outside of the turn, forward tilt
  (pelvis 20 deg, trunk 35 deg), and angulation: they lean 0.85, 0.55 and 0.3 of ``phi``;
* skis on the snow: each ankle is 0.14 m above its contact point (boot and plate), at the lateral position
  where the leg, hip to ankle, has its length: the outside leg longer (``k + 0.05 |sin phi|``), the inside leg
  shorter and its ski 0.08 m ahead; knees by inverse kinematics bending forward (a perfect hinge);
* the calibration at the start: 3 s upright and still, three squats (knees and hips flexed, trunk leaning
  forward, hips back), then the gates simulator's static start, run and static finish.

Sensors: pelvis (sacrum), torso (sternum), head (helmet), thighs (lateral), shanks (front), each at a lever
arm from its segment's joint and rotated by an unknown rotation of up to ``max_misalignment`` deg; specific
force and angular rate in the sensor frame from the positions and orientations on the 1 kHz grid.

Truth: whole-body CoM (boots 1.8 kg at each ankle, skis 4.2 kg at each contact point), LJC, joint centres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Winter (2009) Table 4.1 (Dempster): segment mass [fraction of body mass] and CoM from the proximal end.
MASS = {"head_neck": 0.081, "thorax_abdomen": 0.355, "pelvis": 0.142, "upper_arm": 0.028, "forearm": 0.016,
        "hand": 0.006, "thigh": 0.100, "leg": 0.0465, "foot": 0.0145}  # fmt: skip
COM = {"thorax_abdomen": 0.63, "pelvis": 0.105, "thigh": 0.433, "leg": 0.433}
#: Winter's segment lengths as fractions of the height: thigh (hip-knee), leg (knee-ankle), upper arm.
LEN = {"thigh": 0.245, "leg": 0.246, "upper_arm": 0.186, "forearm": 0.146}
#: Our geometry [fraction of the height]: LJC above the hips, hip half-width, LJC -> C7T1, C7T1 -> head CoM.
LJC_ABOVE_HIPS, HIP_HALF, TRUNK, HEAD = 0.05, 0.048, 0.238, 0.10
BOOT_KG, SKI_KG = 1.8, 4.2
ANKLE_H = 0.14  # ankle above the ski-snow contact [m]
SEGMENTS = ("pelvis", "torso", "head", "femur_r", "femur_l", "tibia_r", "tibia_l")


@dataclass
class SkierConfig:
    """The athlete of ``simulate gates --body`` (units in brackets)."""

    height: float = 1.80  # [m]
    mass: float = 78.0  # [kg]
    calibration: bool = True  # the static posture and squats before the run
    max_misalignment: float = 30.0  # sensor-to-segment rotation, at most [deg]


def _norm(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _rz_ry_rx(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Segment -> course rotations ``Rz(yaw) Ry(pitch) Rx(roll)`` (z down: yaw to the right, roll right side down)."""
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    r = np.empty(np.shape(yaw) + (3, 3))
    r[..., 0, 0] = cy * cp
    r[..., 0, 1] = cy * sp * sr - sy * cr
    r[..., 0, 2] = cy * sp * cr + sy * sr
    r[..., 1, 0] = sy * cp
    r[..., 1, 1] = sy * sp * sr + cy * cr
    r[..., 1, 2] = sy * sp * cr - cy * sr
    r[..., 2, 0] = -sp
    r[..., 2, 1] = cp * sr
    r[..., 2, 2] = cp * cr
    return r


def _random_rotation(rng: np.random.Generator, max_deg: float) -> np.ndarray:
    axis = _norm(rng.normal(size=3))
    ang = np.deg2rad(rng.uniform(0.3, 1.0) * max_deg)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(ang) * k + (1 - np.cos(ang)) * k @ k


def _smooth(x: np.ndarray, n: int = 151) -> np.ndarray:
    k = np.hanning(n)
    k /= k.sum()
    pad = np.pad(x, (n // 2, n - 1 - n // 2), mode="edge")
    return np.convolve(pad, k, mode="valid")


def _leg_ankle(hip, base, right_s, lean, length):
    """Ankle on the line ``base + s right_s`` at ``length`` from the hip, on the outside of the turn.

    The two solutions lie either side of the hip; the leg leans with the body, so the ankle takes the one
    on the outside, blended through ``tanh(lean / 0.15)`` across a transition (continuous: below the hip
    when upright, where the leg is then a little shorter than ``length``).
    """
    d0 = hip - base
    b = np.sum(d0 * right_s, axis=1)
    perp2 = np.sum(d0 * d0, axis=1) - b * b
    # a leg too short to reach the snow line stretches (a soft maximum keeps the motion smooth)
    x = (length**2 - perp2) / 0.01
    disc = 0.01 * np.where(x > 30, x, np.log1p(np.exp(np.minimum(x, 30))))
    s = b - np.tanh(lean / 0.15) * np.sqrt(disc)
    return base + s[:, None] * right_s


def _knee(hip, ankle, l1, l2, pole):
    d = ankle - hip
    dist = np.linalg.norm(d, axis=1)
    dist_c = np.minimum(dist, (l1 + l2) * 0.9999)
    dh = d / dist[:, None]
    a = (l1**2 - l2**2 + dist_c**2) / (2 * dist_c)
    h = np.sqrt(np.maximum(l1**2 - a**2, 0.0))
    p = _norm(pole - np.sum(pole * dh, axis=1)[:, None] * dh)
    return hip + a[:, None] * dh + h[:, None] * p


def _limb_frames(hip, knee, ankle, fallback_y):
    zt = _norm(knee - hip)
    zs = _norm(ankle - knee)
    y = np.cross(zs, zt)
    straight = np.linalg.norm(y, axis=1) < 1e-3
    y = np.where(straight[:, None], fallback_y, y)
    out = []
    for z in (zt, zs):
        yy = _norm(y - np.sum(y * z, axis=1)[:, None] * z)
        out.append(np.stack([np.cross(yy, z), yy, z], axis=-1))
    return out


def _signed_lean(snow: np.ndarray, skiing: np.ndarray, dt: float, g: float = 9.81) -> np.ndarray:
    """The inclination [rad] that balances the turn's lateral acceleration (positive leaning right), from the
    snow path: ``atan(a_right / g)`` while skiing."""
    v = np.gradient(snow[:, :2], dt, axis=0)
    a = np.column_stack([_smooth(np.gradient(v[:, j], dt), 301) for j in range(2)])
    sp = np.maximum(np.linalg.norm(v, axis=1), 1e-6)
    right = np.column_stack([-v[:, 1], v[:, 0]]) / sp[:, None]
    return np.arctan(np.sum(a * right, axis=1) / g) * skiing


def build_skier(tru: dict, cfg: SkierConfig, rng: np.random.Generator, dt: float) -> dict:
    """The skier on the gates simulator's fine grid (module text), the calibration prepended.

    ``tru`` is :func:`sportfusion.gates.sim._truth`'s output; returns the segment rotations and origins,
    sensors (position, rotation), truth CoM and points, all on the extended grid, and ``t_cal`` [s].
    """
    H = cfg.height
    l1, l2 = LEN["thigh"] * H, LEN["leg"] * H
    snow, ter = tru["snow"], tru["terrain"]
    n_run = snow.shape[0]
    skiing = tru["skiing"]
    lean = _signed_lean(snow, skiing, dt)
    # heading and the snow-plane directions along the run
    vs = np.gradient(snow, dt, axis=0)
    head = np.unwrap(np.arctan2(vs[:, 1], vs[:, 0]))
    moving = np.linalg.norm(vs[:, :2], axis=1) > 0.5
    idx = np.flatnonzero(moving)
    head = _smooth(np.interp(np.arange(n_run), idx, head[idx]), 301)
    up = ter.up_normal(snow[:, 0], snow[:, 1])  # out of the snow (z < 0)
    up = _norm((1 - skiing)[:, None] * np.array([0.0, 0.0, -1.0]) + skiing[:, None] * up)
    # posture while running
    phase_k = 0.86 - 0.12 * np.exp(-((lean / 0.25) ** 2))  # lowest across the transitions
    k = 0.995 + (phase_k - 0.995) * skiing
    k = _smooth(k, 101)
    k_out = k + 0.05 * np.abs(np.sin(lean))
    k_in = k - 0.06 * np.abs(np.sin(lean))
    yaw_p = head - 0.25 * lean
    rp = _rz_ry_rx(yaw_p, -np.deg2rad(20.0) * skiing, 0.85 * lean)
    rt = _rz_ry_rx(head - 0.4 * lean, -np.deg2rad(35.0) * skiing, 0.55 * lean)
    rh = _rz_ry_rx(head - 0.2 * lean, -np.deg2rad(10.0) * skiing, 0.3 * lean)
    hgt = ANKLE_H + k * (l1 + l2) * np.cos(lean) + LJC_ABOVE_HIPS * H
    ljc = snow + hgt[:, None] * up
    # calibration before the run: still 3 s, three squats of 2.4 s, still 1 s (feet where the run starts)
    if cfg.calibration:
        tc = np.arange(0.0, 3.0 + 3 * 2.4 + 1.0, dt)
        sq = np.where((tc > 3.0) & (tc < 10.2), np.sin(np.pi * (tc - 3.0) / 2.4) ** 2, 0.0)
        nc = tc.size

        def pre(x):
            return np.concatenate([np.repeat(x[:1], nc, axis=0), x])

        back = np.array([np.cos(head[0]), np.sin(head[0]), 0.0])
        ljc = np.concatenate([ljc[:1] - 0.18 * sq[:, None] * back - 0.0 * up[:1], ljc])
        kc = 0.995 - 0.30 * sq
        hc = ANKLE_H + kc * (l1 + l2) + LJC_ABOVE_HIPS * H
        ljc[:nc] = snow[0] + hc[:, None] * up[0] - 0.18 * sq[:, None] * back
        rp = np.concatenate([_rz_ry_rx(np.full(nc, head[0]), -np.deg2rad(30.0) * sq, 0 * sq), rp])
        rt = np.concatenate([_rz_ry_rx(np.full(nc, head[0]), -np.deg2rad(45.0) * sq, 0 * sq), rt])
        rh = np.concatenate([_rz_ry_rx(np.full(nc, head[0]), -np.deg2rad(30.0) * sq, 0 * sq), rh])
        snow_a, up_a, head_a, lean_a = pre(snow), pre(up), pre(head), pre(lean)
        k_out_a = np.concatenate([kc, k_out])
        k_in_a = np.concatenate([kc, k_in])
        calib = np.concatenate([np.ones(nc, bool), np.zeros(n_run, bool)])
        t_cal = nc * dt
    else:
        snow_a, up_a, head_a, lean_a, k_out_a, k_in_a = snow, up, head, lean, k_out, k_in
        calib = np.zeros(n_run, bool)
        t_cal = 0.0
    n = ljc.shape[0]
    fwd_h = np.stack([np.cos(head_a), np.sin(head_a), np.zeros(n)], axis=-1)
    right_h = np.stack([-np.sin(head_a), np.cos(head_a), np.zeros(n)], axis=-1)
    right_s = _norm(right_h - np.sum(right_h * up_a, axis=1)[:, None] * up_a)
    fwd_s = _norm(fwd_h - np.sum(fwd_h * up_a, axis=1)[:, None] * up_a)
    hip_off = {"r": np.array([0.02 * H, HIP_HALF * H, LJC_ABOVE_HIPS * H]),
               "l": np.array([0.02 * H, -HIP_HALF * H, LJC_ABOVE_HIPS * H])}  # fmt: skip
    hips = {s: ljc + np.einsum("nij,j->ni", rp, o) for s, o in hip_off.items()}
    out_leg = np.where(lean_a > 0, "l", "r")  # leaning right (a right turn): the left leg is outside
    ankles = {}
    for s in ("r", "l"):
        outside = out_leg == s
        length = np.where(outside | calib, k_out_a, k_in_a) * (l1 + l2)
        lead = np.where(outside | calib, 0.0, 0.08 * np.minimum(np.abs(lean_a) / 0.2, 1.0))
        base = snow_a + ANKLE_H * up_a + lead[:, None] * fwd_s
        ankles[s] = _leg_ankle(hips[s], base, right_s, lean_a, length)
    pole = np.einsum("nij,j->ni", rp, np.array([1.0, 0.0, 0.0]))
    seg_rot = {"pelvis": rp, "torso": rt, "head": rh}
    knees, contact = {}, {}
    for s in ("r", "l"):
        knees[s] = _knee(hips[s], ankles[s], l1, l2, pole)
        ft, fs_ = _limb_frames(hips[s], knees[s], ankles[s], np.einsum("nij,j->ni", rp, np.array([0.0, 1.0, 0.0])))
        seg_rot[f"femur_{s}"], seg_rot[f"tibia_{s}"] = ft, fs_
        contact[s] = ankles[s] - ANKLE_H * up_a
    c7 = ljc + np.einsum("nij,j->ni", rt, np.array([0.0, 0.0, -TRUNK * H]))
    head_com = c7 + np.einsum("nij,j->ni", rh, np.array([0.0, 0.0, -HEAD * H]))
    origin = {"pelvis": ljc, "torso": ljc, "head": c7, "femur_r": hips["r"], "femur_l": hips["l"],
              "tibia_r": knees["r"], "tibia_l": knees["l"]}  # fmt: skip
    # truth CoM (Dempster / Winter), boots at the ankles, skis at the contact points
    M = cfg.mass
    parts = [
        (MASS["pelvis"], ljc + np.einsum("nij,j->ni", rp, np.array([0.0, 0.0, COM["pelvis"] * LJC_ABOVE_HIPS * H]))),
        (MASS["thorax_abdomen"], c7 + COM["thorax_abdomen"] * (ljc - c7)),
        (MASS["head_neck"], head_com),
        (2 * (MASS["upper_arm"] + MASS["forearm"] + MASS["hand"]),
         c7 + np.einsum("nij,j->ni", rt, np.array([0.08 * H, 0.0, 0.14 * H]))),
    ]  # fmt: skip
    for s in ("r", "l"):
        parts.append((MASS["thigh"], hips[s] + COM["thigh"] * (knees[s] - hips[s])))
        parts.append((MASS["leg"], knees[s] + COM["leg"] * (ankles[s] - knees[s])))
        parts.append((MASS["foot"], ankles[s] + 0.05 * fwd_s - 0.04 * up_a))
    com = sum(m * M * p for m, p in parts)
    tot = M
    for s in ("r", "l"):
        com = com + BOOT_KG * ankles[s] + SKI_KG * contact[s]
        tot += BOOT_KG + SKI_KG
    com = com / tot
    # sensors: lever arm from the segment's origin (segment frame), random strap rotation
    levers = {
        "pelvis": np.array([-0.10, 0.0, 0.03]),
        "torso": np.array([0.11, 0.0, -0.16 * H]),
        "head": np.array([-0.04, 0.0, -0.16 * H]),
        "femur_r": np.array([0.0, 0.08, 0.5 * l1]),
        "femur_l": np.array([0.0, -0.08, 0.5 * l1]),
        "tibia_r": np.array([0.05, 0.0, 0.45 * l2]),
        "tibia_l": np.array([0.05, 0.0, 0.45 * l2]),
    }
    sensors = {}
    for seg in SEGMENTS:
        off = _random_rotation(rng, cfg.max_misalignment)
        lev = levers[seg] + rng.normal(0, 0.01, 3)
        pos = origin[seg] + np.einsum("nij,j->ni", seg_rot[seg], lev)
        sensors[seg] = {"pos": pos, "rot": np.einsum("nij,jk->nik", seg_rot[seg], off), "lever": lev, "offset": off}
    points = {"ljc": ljc, "hip_r": hips["r"], "hip_l": hips["l"], "knee_r": knees["r"], "knee_l": knees["l"],
              "ankle_r": ankles["r"], "ankle_l": ankles["l"], "ski_r": contact["r"], "ski_l": contact["l"],
              "sternum": c7, "head": head_com}  # fmt: skip
    return {
        "rot": seg_rot,
        "origin": origin,
        "sensors": sensors,
        "com": com,
        "points": points,
        "t_cal": t_cal,
        "calib": calib,
        "heading0": float(head[0]),
        "up": up_a,
    }


def _course_to_ned(azimuth_deg: float) -> np.ndarray:
    a = np.deg2rad(azimuth_deg)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def _quat_bo(r_sc: np.ndarray, azimuth_deg: float) -> np.ndarray:
    """q_BO (NED -> sensor, scalar first) of sensor -> course rotations (n, 3, 3)."""
    r_sn = np.einsum("ij,njk->nik", _course_to_ned(azimuth_deg), r_sc)
    m = np.swapaxes(r_sn, -1, -2)  # NED -> sensor
    tr = np.trace(m, axis1=1, axis2=2)
    q0 = 0.5 * np.sqrt(np.maximum(1 + tr, 1e-12))
    # Shepperd-free form is fine here: the attitudes never reach 180 deg from NED in one step; use the robust
    # eigen-free branch selection of the largest component
    q = np.empty((m.shape[0], 4))
    q[:, 0] = q0
    q[:, 1] = (m[:, 1, 2] - m[:, 2, 1]) / (4 * q0)
    q[:, 2] = (m[:, 2, 0] - m[:, 0, 2]) / (4 * q0)
    q[:, 3] = (m[:, 0, 1] - m[:, 1, 0]) / (4 * q0)
    bad = tr < -0.5
    if bad.any():  # near 180 deg: the largest-diagonal branch
        from scipy.spatial.transform import Rotation

        xyzw = Rotation.from_matrix(np.swapaxes(m[bad], -1, -2)).as_quat()
        q[bad] = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q


def attach_body(tru: dict, cfg, dt: float) -> tuple[dict, dict]:  # noqa: ANN001 - GatesConfig
    """Replace the gates simulator's sacrum truth by the skier's pelvis sensor (calibration prepended).

    Returns the new ``tru`` (``pos vel acc q`` of the pelvis sensor; every other array of the fine grid
    extended over the calibration by its first sample: the athlete stands at the start) and the body
    (:func:`build_skier`'s output plus ``dt``).
    """
    rng = np.random.default_rng(cfg.seed + 7919)  # the body's own stream: the course is that of the same seed
    sk = SkierConfig(height=cfg.height, mass=cfg.body_mass, max_misalignment=cfg.max_misalignment)
    body = build_skier(tru, sk, rng, dt)
    nc = int(round(body["t_cal"] / dt))
    n_run = tru["t"].size
    out = dict(tru)
    for key, v in tru.items():
        if isinstance(v, np.ndarray) and v.shape[:1] == (n_run,):
            out[key] = np.concatenate([np.repeat(v[:1], nc, axis=0), v])
    out["t"] = np.arange(n_run + nc) * dt
    ps = body["sensors"]["pelvis"]
    out["pos"] = ps["pos"]
    out["vel"] = np.gradient(out["pos"], dt, axis=0)
    out["acc"] = np.gradient(out["vel"], dt, axis=0)
    out["q"] = _quat_bo(ps["rot"], cfg.azimuth_deg)
    out["t_run"] = (tru["t_run"][0] + body["t_cal"], tru["t_run"][1] + body["t_cal"])
    body["dt"] = dt
    body["sk"] = sk
    return out, body


def body_streams(
    body: dict,
    ti: np.ndarray,
    cfg,  # noqa: ANN001 - GatesConfig
    rng: np.random.Generator,
    g: float,
    rates_of,  # noqa: ANN001 - sportfusion.gates.sim.body_rates
    speed: np.ndarray,
    t_move: tuple[float, float],
) -> list:
    """IMU streams of the six sensors other than the pelvis (columns ``<segment>__acc_x`` ...), at times ``ti``:
    each a unit like the pelvis one (:func:`sportfusion.gates.sim_sensors.measure_unit`: scale, misalignment,
    bias, temperature, noise, quantisation, range and ski chatter growing with ``speed`` [m/s])."""
    from sportfusion.core.session import Stream
    from sportfusion.gates.sim_sensors import measure_unit

    dt = body["dt"]
    k = np.clip(np.rint(ti / dt).astype(int), 0, body["com"].shape[0] - 1)
    no_mag = (ti[:2], np.zeros((2, 3)), np.zeros(2))
    out = []
    for seg in SEGMENTS[1:]:
        s = body["sensors"][seg]
        acc = np.gradient(np.gradient(s["pos"], dt, axis=0), dt, axis=0)[k]
        f = np.einsum("nji,nj->ni", s["rot"][k], acc - np.array([0.0, 0.0, g]))  # course -> sensor
        w = rates_of(_quat_bo(s["rot"], cfg.azimuth_deg), dt)[k]
        fa, wg, _ = measure_unit(cfg.unit, rng, ti, f, w, speed, *no_mag, t_move)
        cols = {f"{seg}__acc_{a}": fa[:, i] for i, a in enumerate("xyz")}
        cols.update({f"{seg}__gyr_{a}": wg[:, i] for i, a in enumerate("xyz")})
        out.append(Stream(seg, ti, cols))
    return out


def body_truth_columns(body: dict, ts: np.ndarray) -> dict:
    """Truth of the body at times ``ts``: ``true_com_*``, ``true_com_v*`` (course frame), ``true_ljc_*``, and
    in the body model's frame J (heading of the calibration posture, z down) relative to the LJC:
    ``true_com_rel_*`` and ``true_<point>_rel_*``."""
    dt = body["dt"]
    k = np.clip(np.rint(ts / dt).astype(int), 0, body["com"].shape[0] - 1)
    com = body["com"]
    vcom = np.gradient(com, dt, axis=0)
    ljc = body["points"]["ljc"]
    c, s = np.cos(body["heading0"]), np.sin(body["heading0"])
    to_j = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # course -> J
    cols: dict = {}
    for i, a in enumerate("xyz"):
        cols[f"true_com_{a}"] = com[k, i]
        cols[f"true_com_v{a}"] = vcom[k, i]
        cols[f"true_ljc_{a}"] = ljc[k, i]
    rel = (com[k] - ljc[k]) @ to_j.T
    for i, a in enumerate("xyz"):
        cols[f"true_com_rel_{a}"] = rel[:, i]
    for name, p in body["points"].items():
        if name == "ljc":
            continue
        r = (p[k] - ljc[k]) @ to_j.T
        for i, a in enumerate("xyz"):
            cols[f"true_{name}_rel_{a}"] = r[:, i]
    return cols
