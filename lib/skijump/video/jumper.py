"""The jumper (skis, boots, legs, body, arms, helmet) and background extras, as 3-D parts over time.

Touch-down model: see :mod:`sportfusion.skijump.video.render`.  Parts are lists of
``(kind, points, radius, colour)``: ``"poly"`` (the convex hull of the
projected points is filled) or ``"capsule"`` (a thick line, or a disc when
its two ends coincide) of ``radius`` metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.interpolate import CubicSpline

from sportfusion.core.errors import InputError
from sportfusion.core.session import time_step_problem
from sportfusion.skijump.video.camera import Camera, Slope
from sportfusion.skijump.video.scene import Scene, _rgb

Part = tuple[str, np.ndarray, float, tuple[int, int, int]]


@dataclass
class Trajectory:
    """A jumper's truth motion around the landing (hill frame).

    Attributes
    ----------
    t : ndarray (n,)
        Time [s], strictly increasing.
    r : ndarray (n, 3)
        Position of the tracked point (hill frame, z down) [m].
    t_touchdown : float
        Time the skis touch the snow [s].
    """

    t: np.ndarray
    r: np.ndarray
    t_touchdown: float

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.r = np.asarray(self.r, dtype=float)
        if self.t.ndim != 1 or self.r.shape != (self.t.size, 3) or self.t.size < 4:
            raise InputError("trajectory: expected times (n,) and positions (n, 3) with n >= 4")
        if not np.all(np.diff(self.t) > 0):
            raise InputError(f"trajectory: times must be strictly increasing: {time_step_problem(self.t)}")
        if not self.t[0] < self.t_touchdown < self.t[-1]:
            raise InputError("trajectory: the touch-down time lies outside the trajectory's time span")


def _smoothstep(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


SUITS = ("#d62828", "#1d3557", "#f77f00", "#2a9d8f", "#6a4c93", "#e63946", "#264653", "#8ab17d")
SKIS = ("#1b1b1b", "#22306b", "#5a1a1a", "#202020")


@dataclass
class Look:
    """Colours of the jumper (BGR)."""

    suit: tuple[int, int, int]
    suit_dark: tuple[int, int, int]
    skis: tuple[int, int, int]
    boots: tuple[int, int, int]
    helmet: tuple[int, int, int]


class JumperModel:
    """Poses of the jumper (3-D parts in the hill frame) over time."""

    SKI_LENGTH = 2.5  # [m]
    SKI_WIDTH = 0.11
    SKI_THICK = 0.05
    TIP = 0.18  # upturned tip beyond the flat sole [m]
    V_ANGLE = np.radians(32.0)  # opening of the V in flight
    V_ROLL = np.radians(18.0)  # skis rolled in the V
    FLIGHT_PITCH = np.radians(9.0)  # skis' tips above the slope line in flight
    FLATTEN = 0.35  # [s] skis flatten onto the slope before the touch-down
    V_CLOSE = (0.65, 0.3)  # [s] before the touch-down: V starts to close / is parallel

    def __init__(self, traj: Trajectory, slope: Slope, look: Look) -> None:
        self.slope, self.look = slope, look
        self.t_td = float(traj.t_touchdown)
        # restrict the spline to the landing neighbourhood for speed
        sel = (traj.t > self.t_td - 4.0) & (traj.t < self.t_td + 4.0)
        if sel.sum() < 4:
            sel[:] = True
        self.spline = CubicSpline(traj.t[sel], traj.r[sel])
        r_td = self.spline(self.t_td)
        xp, d = slope.foot(np.array([r_td[0]]), np.array([r_td[2]]))
        self.d_td = float(d[0])
        self.x_td = float(xp[0])
        self.y_td = float(r_td[1])
        self.s_td = float(slope.profile.jump_length(self.x_td))

    def state(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Ski frame quantities at times ``t`` (arrays)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        r = self.spline(t)
        v = self.spline(t, 1)
        xp, d = self.slope.foot(r[:, 0], r[:, 2])
        tau = self.t_td - t  # > 0 before the touch-down
        h = np.where(tau > 0, np.maximum(d - self.d_td, 0.0), 0.0)
        pitch = self.FLIGHT_PITCH * _smoothstep(tau / self.FLATTEN)
        a, b = self.V_CLOSE
        wv = _smoothstep((tau - b) / (a - b))
        heading = np.arctan2(v[:, 1], np.hypot(v[:, 0], v[:, 2]))
        land = _smoothstep((0.55 - tau) / 0.55)  # 0 in flight .. 1 from the touch-down on
        tele = _smoothstep(-tau / 0.35)
        return {
            "xp": xp,
            "y": r[:, 1],
            "h": h,
            "pitch": pitch,
            "wv": wv,
            "heading": heading,
            "land": land,
            "tele": tele,
        }

    def parts(self, st: dict[str, np.ndarray], i: int) -> list[Part]:
        """3-D parts at state index ``i``: (kind, points, radius [m], colour); kind 'poly' or 'capsule'."""
        sl, lk = self.slope, self.look
        xp = float(st["xp"][i])
        zp = float(sl.profile.z(xp))
        t_hat, n_hat = sl.axes_fast(xp)
        lat = np.array([0.0, 1.0, 0.0])
        psi = float(st["heading"][i])
        fwd0 = np.cos(psi) * t_hat + np.sin(psi) * lat
        lat0 = -np.sin(psi) * t_hat + np.cos(psi) * lat
        mid = np.array([xp, float(st["y"][i]), zp])
        h, th, wv = float(st["h"][i]), float(st["pitch"][i]), float(st["wv"][i])
        land, tele = float(st["land"][i]), float(st["tele"][i])
        L, Wd, T = self.SKI_LENGTH, self.SKI_WIDTH, self.SKI_THICK
        out: list[Part] = []
        ankles = []
        for side in (-1.0, 1.0):
            yaw = side * 0.5 * self.V_ANGLE * wv
            roll = side * self.V_ROLL * wv
            f = np.cos(yaw) * fwd0 + np.sin(yaw) * lat0
            lside = -np.sin(yaw) * fwd0 + np.cos(yaw) * lat0
            # pitch the ski (tips up) about its lateral axis
            f = np.cos(th) * f + np.sin(th) * n_hat
            up = np.cross(f, lside)
            up = up if up @ n_hat > 0 else -up
            # roll about the ski's long axis
            lr = np.cos(roll) * lside + np.sin(roll) * up
            ur = np.cross(f, lr)
            ur = ur if ur @ n_hat > 0 else -ur
            lift = 0.5 * Wd * abs(np.sin(roll))
            spread = 0.12 - 0.07 * wv  # lateral position of the tail (V: tails together)
            # the ski's visible extent (tail .. upturned tip, L + TIP) is centred on the foot point
            tail = mid - 0.5 * (L + self.TIP) * fwd0 + side * spread * lat0 + (h + lift) * n_hat
            tail = tail + side * 0.18 * tele * fwd0  # telemark: one ski forward
            corners = np.array(
                [tail + a * f + b * lr + c * ur for a in (0.0, L) for b in (-0.5 * Wd, 0.5 * Wd) for c in (0.0, T)]
            )
            out.append(("poly", corners, 0.0, lk.skis))
            # upturned tip
            tip0 = tail + L * f
            tip1 = tip0 + self.TIP * f + 0.07 * ur
            out.append(("capsule", np.array([tip0 + 0.5 * T * ur, tip1]), 0.5 * T, lk.skis))
            # boot
            b0 = tail + 0.5 * L * f + T * ur
            out.append(("capsule", np.array([b0 - 0.12 * f + 0.06 * ur, b0 + 0.12 * f + 0.06 * ur]), 0.07, lk.boots))
            ankles.append(b0 + 0.16 * ur)
        up_n = n_hat
        ank = 0.5 * (ankles[0] + ankles[1])

        def u(angle_deg: float) -> np.ndarray:
            a = np.radians(angle_deg)
            return np.cos(a) * fwd0 + np.sin(a) * up_n

        def blend(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return (1 - land) * a + land * b

        knee = ank + blend(0.48 * u(40.0), 0.46 * u(72.0))
        hip = knee + blend(0.46 * u(30.0), 0.44 * u(118.0))
        shoulder = hip + blend(0.58 * u(14.0), 0.56 * u(62.0))
        head = shoulder + blend(0.26 * u(14.0), 0.24 * u(66.0))
        for k, ankle in enumerate(ankles):
            side = -1.0 if k == 0 else 1.0
            kn = knee + side * 0.1 * lat0
            out.append(("capsule", np.array([ankle, kn]), 0.075, lk.suit_dark))
            out.append(("capsule", np.array([kn, hip + side * 0.09 * lat0]), 0.09, lk.suit))
        out.append(("capsule", np.array([hip, shoulder]), 0.16, lk.suit))
        for side in (-1.0, 1.0):
            sh = shoulder + side * 0.2 * lat0
            hand = blend(
                hip + side * 0.28 * lat0 - 0.05 * up_n + 0.1 * fwd0, shoulder + side * 0.75 * lat0 - 0.25 * up_n
            )
            out.append(("capsule", np.array([sh, hand]), 0.05, lk.suit))
        out.append(("capsule", np.array([head, head]), 0.13, lk.helmet))
        return out


def draw_parts(
    camera: Camera,
    parts: list[Part],
    colour: np.ndarray,
    alpha: np.ndarray,
    origin: tuple[int, int],
) -> None:
    """Draw parts (far first) into a colour and an alpha canvas whose (0, 0) is pixel ``origin``."""
    if not parts:
        return
    ox, oy = origin
    sizes = [len(p[1]) for p in parts]
    px_all, depth_all = camera.project(np.concatenate([p[1] for p in parts]))
    px_all = px_all - np.array([ox, oy])
    keyed = []
    start = 0
    for (kind, _, rad, col), n in zip(parts, sizes, strict=True):
        px, depth = px_all[start : start + n], depth_all[start : start + n]
        start += n
        if np.any(depth <= 0.5) or not np.all(np.isfinite(px)):
            continue
        keyed.append((float(np.mean(depth)), kind, px, float(np.mean(depth)), rad, col))
    keyed.sort(key=lambda k: -k[0])
    for _, kind, px, depth, rad, col in keyed:
        if kind == "poly":
            hull = cv2.convexHull(px.astype(np.float32)).reshape(-1, 2)
            pts = np.round(hull * 16).astype(np.int32)
            cv2.fillConvexPoly(colour, pts, col, lineType=cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(alpha, pts, 255, lineType=cv2.LINE_AA, shift=4)
        else:
            r_px = max(rad * camera.focal / depth, 0.5)
            a = np.round(px[0] * 16).astype(int)
            b = np.round(px[-1] * 16).astype(int)
            if np.array_equal(a, b):
                rr = int(round(r_px * 16))
                cv2.circle(colour, tuple(a), rr, col, -1, cv2.LINE_AA, 4)
                cv2.circle(alpha, tuple(a), rr, 255, -1, cv2.LINE_AA, 4)
            else:
                thick = max(1, int(round(2 * r_px)))
                cv2.line(colour, tuple(a), tuple(b), col, thick, cv2.LINE_AA, 4)
                cv2.line(alpha, tuple(a), tuple(b), 255, thick, cv2.LINE_AA, 4)


class Extras:
    """A person walking and flags waving behind the far side of the slope."""

    def __init__(self, scene: Scene, aim_s: float, person: bool, flags: bool, rng: np.random.Generator) -> None:
        self.scene = scene
        far = scene.far
        self.person = person
        self.flags = flags
        self.p_y = far * (scene.half + 4.5)
        self.p_s0 = aim_s - 6.0 + 3.0 * rng.random()
        self.p_speed = 1.0 + 0.6 * rng.random()
        self.f_s = aim_s + np.array([-9.0, -1.5, 6.0]) + rng.normal(0, 1.0, 3)
        self.f_y = far * (scene.half + 3.0)
        self.f_col = [_rgb(h) for h in ("#e63946", "#ffb703", "#219ebc")]
        self.phase = rng.random(3) * 6.28

    def parts(self, t: float) -> list[Part]:
        sl = self.scene.slope
        out: list[Part] = []
        up = np.array([0.0, 0.0, -1.0])
        if self.person:
            s = self.p_s0 + self.p_speed * t
            foot = sl.point_fast(s, self.p_y)
            fwd = sl.axes_fast(foot[0])[0]
            swing = 0.25 * np.sin(2 * np.pi * 0.9 * t)
            hip = foot + 0.9 * up
            for sgn in (-1, 1):
                out.append(("capsule", np.array([hip, foot + sgn * swing * fwd]), 0.08, _rgb("#333344")))
            sh = hip + 0.6 * up
            out.append(("capsule", np.array([hip, sh]), 0.17, _rgb("#8d0801")))
            for sgn in (-1, 1):
                out.append(("capsule", np.array([sh, hip + 0.1 * up - sgn * swing * fwd]), 0.05, _rgb("#8d0801")))
            out.append(("capsule", np.array([sh + 0.22 * up, sh + 0.22 * up]), 0.11, _rgb("#f1c27d")))
        if self.flags:
            for k, s in enumerate(self.f_s):
                base = sl.point_fast(s, self.f_y)
                fwd = sl.axes_fast(base[0])[0]
                top = base + 2.2 * up
                out.append(("capsule", np.array([base, top]), 0.025, _rgb("#555555")))
                wave = 0.25 * np.sin(2 * np.pi * 1.3 * t + self.phase[k])
                lat = np.array([0.0, 1.0, 0.0])
                a, b = top, top - 0.5 * up
                c = b + 0.8 * fwd + wave * lat
                d = a + 0.8 * fwd + 0.6 * wave * lat
                out.append(("poly", np.array([a, b, c, d]), 0.0, self.f_col[k]))
        return out


def random_look(rng: np.random.Generator) -> Look:
    suit = _rgb(SUITS[int(rng.integers(len(SUITS)))])
    dark = tuple(int(c * 0.6) for c in suit)
    return Look(suit, dark, _rgb(SKIS[int(rng.integers(len(SKIS)))]), _rgb("#111111"), _rgb("#f4f4f4"))  # type: ignore[arg-type]
