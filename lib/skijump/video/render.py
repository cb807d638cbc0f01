"""Render the landing of a (simulated) jump as filmed by a fixed camera beside the landing slope.

The scene: the landing slope (the hill's landing profile extruded across the
hill, snow texture), distance markers every metre on both sides of the slope
and numbered boards every 5 m, advertising boards and a forest behind the far
side, optionally a person walking and flags waving behind the far side; the
jumper (two skis -- in V during the flight, parallel before the touch-down,
in a telemark after it -- boots, legs, body, arms, helmet) following the
trajectory.  Frames get motion blur (sub-frame poses over the exposure),
sensor noise and the lossy ``mp4v`` compression of :class:`cv2.VideoWriter`.

Touch-down model
----------------
The trajectory is that of a point on the jumper (the simulated IMU); the skis'
middle lies under its foot point on the profile.  Before the touch-down time
``t_td`` the skis' lowest point is ``d(t) - d(t_td)`` above the snow, ``d`` the
point's height above the profile along its normal, and the skis flatten onto
the slope (pitch relative to the slope -> 0) over the last ``flatten`` seconds;
from ``t_td`` on both skis lie on the snow.  So the truth the video shows is:
touch-down at ``t_td``, the middle of the skis at the foot point of
``r(t_td)`` -- the jump length ``s`` of that point.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.skijump.video.camera import Camera, Profile, Slope, focal_px
from sportfusion.skijump.video.jumper import Extras, JumperModel, Part, Trajectory, draw_parts, random_look
from sportfusion.skijump.video.markers import Markers
from sportfusion.skijump.video.scene import Scene

FOURCC = "mp4v"


# ----------------------------------------------------------------------------- inputs


@dataclass
class RenderOptions:
    """What the camera films and how (SI units; pixels where said).

    Attributes
    ----------
    width, height : int
        Image size [px].
    fps : float
        Frame rate [1/s] (25-60).
    before, after : float
        Seconds filmed before and after the touch-down [s].
    focal_35mm : float or None
        35-mm equivalent focal length [mm]; None: the horizontal field of view
        spans ``field`` metres at the aim point.
    field : float
        Field of view across the image at the aim point when ``focal_35mm`` is None [m].
    camera : tuple (s, y, h)
        Camera station along the slope (jump length of the point beside which it
        stands) [m], lateral position [m] (negative: left of the hill looking
        downhill), height of the lens above the snow there [m].  ``s`` NaN: beside
        the aim point.
    aim : tuple (s, y) or None
        Aim point on the slope [m]; None: the touch-down point.
    slope_width : float
        Width of the landing slope between the two marker lines [m].
    noise : float
        Sensor noise, standard deviation [digital numbers of 0-255].
    shutter : float
        Exposure time as a fraction of the frame interval [1] (motion blur).
    blur_samples : int
        Sub-frame poses averaged over the exposure.
    person, flags : bool
        A person walking / flags waving behind the far side of the slope.
    marker_noise : float
        Reading error added to the marker pixels written for the user [px] (1-sigma); the
        default 0.5 px is a careful reading off ``video-jumplength calibrate``'s grid frame.
    clock : float
        Phase of the camera's frame clock: frames are taken at ``clock + k / fps`` [s].
    seed : int
        Seed of the scene's randomness (texture, colours, noise).
    """

    width: int = 1280
    height: int = 720
    fps: float = 50.0
    before: float = 1.2
    after: float = 0.8
    focal_35mm: float | None = None
    field: float = 26.0
    camera: tuple[float, float, float] = (float("nan"), -38.0, 8.0)
    aim: tuple[float, float] | None = None
    slope_width: float = 28.0
    noise: float = 2.0
    shutter: float = 0.3
    blur_samples: int = 5
    person: bool = False
    flags: bool = False
    marker_noise: float = 0.5
    clock: float = 0.0
    seed: int = 0

    def check(self) -> None:
        """Raise :class:`InputError` for an option out of its range."""
        if not 25.0 <= self.fps <= 60.0:
            raise InputError(f"video frame rate {self.fps} /s; expected 25 to 60 frames per second")
        if not (64 <= self.width <= 4096 and 64 <= self.height <= 4096):
            raise InputError(f"video size {self.width}x{self.height} px; expected 64 to 4096 pixels each way")
        if self.focal_35mm is not None and not 5.0 <= self.focal_35mm <= 2000.0:
            raise InputError(f"focal length {self.focal_35mm} mm; expected 5 to 2000 mm (35-mm equivalent)")
        if not self.field > 1.0:
            raise InputError(f"field of view {self.field} m; expected more than 1 m")
        if not self.camera[2] > 0.5:
            raise InputError(f"camera height {self.camera[2]} m above the snow; expected more than 0.5 m")
        if not abs(self.camera[1]) > self.slope_width / 2 + 1.0:
            raise InputError(
                f"camera lateral position {self.camera[1]} m is on the slope; expected beside it "
                f"(|y| > {self.slope_width / 2 + 1:.1f} m)"
            )
        if not (0 < self.shutter <= 1 and self.blur_samples >= 1 and self.noise >= 0 and self.marker_noise >= 0):
            raise InputError("shutter in (0, 1], blur samples >= 1, noise >= 0 and marker noise >= 0 expected")
        if not (self.before > 0 and self.after > 0):
            raise InputError("seconds before and after the touch-down must be positive")


@dataclass
class RenderResult:
    """What the renderer wrote and the truth a video reading should reproduce.

    Attributes
    ----------
    camera : Camera
    markers : Markers
        Foot pixels of the distance markers inside the frame (plus reading noise).
    t0 : float
        Time of frame 0 on the trajectory's clock [s].
    fps : float
        Frame rate [1/s].
    n_frames : int
    touchdown_frame : int
        First frame at or after the touch-down (both skis on the snow).
    touchdown_frame_exact : float
        Touch-down instant in frame units (``(t_td - t0) fps``).
    jump_length : float
        Distance of the skis' middle at the touch-down along the profile from F [m].
    touchdown_y : float
        Lateral position of the skis' middle at the touch-down [m].
    """

    camera: Camera
    markers: Markers
    t0: float
    fps: float
    n_frames: int
    touchdown_frame: int
    touchdown_frame_exact: float
    jump_length: float
    touchdown_y: float
    meta: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """JSON-able truth of the video (for a truth table's metadata)."""
        return {
            "fps": self.fps,
            "frames": self.n_frames,
            "t0": round(self.t0, 6),
            "touchdown_frame": self.touchdown_frame,
            "touchdown_frame_exact": round(self.touchdown_frame_exact, 4),
            "jump_length": round(self.jump_length, 4),
            "touchdown_y": round(self.touchdown_y, 4),
            "camera_position": [round(float(v), 3) for v in self.camera.position],
            "focal_px": round(self.camera.focal, 3),
            "size": [self.camera.width, self.camera.height],
        }


# ----------------------------------------------------------------------------- helpers
def _smoothstep(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


def make_camera(slope: Slope, opts: RenderOptions, aim_s: float, aim_y: float = 0.0) -> Camera:
    """The camera of ``opts`` aimed at the slope point ``(aim_s, aim_y)`` [m]."""
    s_cam, y_cam, h_cam = opts.camera
    if not np.isfinite(s_cam):
        s_cam = aim_s
    foot = slope.point(s_cam, y_cam)
    # the lens stands h_cam above the snow (vertically)
    pos = foot + np.array([0.0, 0.0, -h_cam])
    target = slope.point(aim_s, aim_y)
    dist = float(np.linalg.norm(target - pos))
    if opts.focal_35mm is not None:
        f = focal_px(opts.focal_35mm, opts.width)
    else:
        f = opts.width * dist / opts.field
    return Camera.look_at(pos, target, f, opts.width, opts.height)


# ----------------------------------------------------------------------------- video
def _noise_bank(rng: np.random.Generator, shape: tuple[int, ...], sigma: float, n: int = 4) -> list[np.ndarray]:
    return [np.clip(rng.normal(0.0, sigma, shape), -127, 127).astype(np.int16) for _ in range(n)]


def render_landing(
    path: str | Path,
    traj: Trajectory,
    profile: Profile,
    opts: RenderOptions,
    progress: object = None,
) -> RenderResult:
    """Render the landing to ``path`` (mp4v) and return the camera, markers and truth.

    Parameters
    ----------
    path : str or Path
        Output video (``.mp4``).
    traj : Trajectory
        Truth motion around the landing.
    profile : Profile
        The hill's landing profile.
    opts : RenderOptions
    progress : callable, optional
        ``progress(iterable, length, label)`` wrapping the frame loop.

    Raises
    ------
    InputError
        Options out of range, or the video cannot be written.
    """
    opts.check()
    rng = np.random.default_rng(opts.seed)
    slope = Slope(profile)
    jumper = JumperModel(traj, slope, random_look(rng))
    aim_s, aim_y = opts.aim if opts.aim is not None else (jumper.s_td, 0.0)
    camera = make_camera(slope, opts, float(aim_s), float(aim_y))
    scene = Scene(slope, camera, opts.slope_width, rng)
    extras = Extras(scene, float(aim_s), opts.person, opts.flags, rng)
    fps = float(opts.fps)
    t0 = float(opts.clock + np.floor((jumper.t_td - opts.before - opts.clock) * fps) / fps)
    t_end = jumper.t_td + opts.after
    n = int(np.floor((t_end - t0) * fps)) + 1
    if t0 < traj.t[0] or t0 + (n - 1) / fps > traj.t[-1]:
        raise InputError(
            f"the trajectory covers {traj.t[0]:.2f}..{traj.t[-1]:.2f} s; the video needs "
            f"{t0:.2f}..{t0 + (n - 1) / fps:.2f} s around the touch-down"
        )
    exact = (jumper.t_td - t0) * fps
    td_frame = int(np.ceil(exact - 1e-9))
    W, H = camera.width, camera.height
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*FOURCC), fps, (W, H))
    if not writer.isOpened():
        raise InputError(f"cannot write the video {path}; expected a writable .mp4 path")
    bank = _noise_bank(rng, (H, W, 3), opts.noise) if opts.noise > 0 else []
    # all sub-frame times at once
    m = opts.blur_samples
    offs = (np.arange(m) + 0.5) / m - 0.5 if m > 1 else np.zeros(1)
    times = t0 + np.arange(n)[:, None] / fps + offs[None, :] * opts.shutter / fps
    st = jumper.state(times.ravel())
    frames = range(n)
    if progress is not None:
        frames = progress(frames, n, "render")  # type: ignore[operator]
    try:
        for k in frames:
            frame = scene.image.copy()
            tk = float(times[k, m // 2])
            if opts.person or opts.flags:
                _composite(frame, camera, [extras.parts(tk)], blur=False)
            poses = [jumper.parts(st, k * m + j) for j in range(m)]
            _composite(frame, camera, poses, blur=True)
            if bank:
                noise = bank[k % len(bank)]
                dy, dx = int(rng.integers(0, H)), int(rng.integers(0, W))
                noise = np.roll(noise, (dy, dx), (0, 1))
                frame = cv2.add(frame.astype(np.int16), noise, dtype=cv2.CV_16S)
                frame = np.clip(frame, 0, 255).astype(np.uint8)
            writer.write(frame)
    finally:
        writer.release()
    markers = scene.markers(opts.marker_noise)
    return RenderResult(
        camera=camera,
        markers=markers,
        t0=t0,
        fps=fps,
        n_frames=n,
        touchdown_frame=td_frame,
        touchdown_frame_exact=float(exact),
        jump_length=jumper.s_td,
        touchdown_y=jumper.y_td,
    )


def _composite(
    frame: np.ndarray,
    camera: Camera,
    poses: list[list[Part]],
    blur: bool,
) -> None:
    """Draw one object (several sub-frame poses averaged when ``blur``) over ``frame`` in place."""
    pts = []
    for parts in poses:
        for _, p, _rad, _ in parts:
            px, depth = camera.project(p)
            if np.all(depth > 0.5):
                pts.append(px)
    if not pts:
        return
    allpx = np.concatenate(pts)
    allpx = allpx[np.all(np.isfinite(allpx), 1)]
    if allpx.size == 0:
        return
    H, W = frame.shape[:2]
    pad = 12
    x0 = int(max(0, np.floor(allpx[:, 0].min()) - pad))
    y0 = int(max(0, np.floor(allpx[:, 1].min()) - pad))
    x1 = int(min(W, np.ceil(allpx[:, 0].max()) + pad + 1))
    y1 = int(min(H, np.ceil(allpx[:, 1].max()) + pad + 1))
    if x1 <= x0 or y1 <= y0:
        return
    acc_c = np.zeros((y1 - y0, x1 - x0, 3), np.float32)
    acc_a = np.zeros((y1 - y0, x1 - x0), np.float32)
    for parts in poses:
        col = np.zeros((y1 - y0, x1 - x0, 3), np.uint8)
        alp = np.zeros((y1 - y0, x1 - x0), np.uint8)
        draw_parts(camera, parts, col, alp, (x0, y0))
        acc_c += col
        acc_a += alp
    acc_c /= len(poses)
    acc_a /= 255.0 * len(poses)
    if blur:
        acc_c = cv2.GaussianBlur(acc_c, (0, 0), 0.45)
        acc_a = cv2.GaussianBlur(acc_a, (0, 0), 0.45)
    roi = frame[y0:y1, x0:x1].astype(np.float32)
    out = acc_c + roi * (1.0 - acc_a[..., None])
    frame[y0:y1, x0:x1] = np.clip(out, 0, 255).astype(np.uint8)


# ----------------------------------------------------------------------------- a test trajectory
def parabolic_landing(
    profile: Profile,
    jump_length: float,
    speed: float = 26.0,
    clearance: float = 0.25,
    g_eff: float = 5.5,
    lateral: float = 0.0,
    lateral_speed: float = 0.0,
    dt: float = 0.01,
) -> Trajectory:
    """A simple landing trajectory: a parabola meeting the landing profile, then sliding along it.

    The tracked point flies on a parabola with downward acceleration ``g_eff``
    (gravity less lift) [m/s^2], reaches ``clearance`` [m] above the profile
    (normal distance) exactly above the point at ``jump_length`` [m] from F --
    the touch-down -- then sinks onto the profile within 0.3 s while sliding
    along it at constant speed.

    Parameters
    ----------
    profile : Profile
    jump_length : float
        Distance of the touch-down along the profile from F [m].
    speed : float
        Speed at the touch-down [m/s].
    clearance : float
        Height of the tracked point above the skis' soles [m].
    g_eff : float
        Effective downward acceleration in flight [m/s^2].
    lateral, lateral_speed : float
        Lateral position at the touch-down [m] and lateral speed [m/s].
    dt : float
        Sample interval [s].
    """
    slope = Slope(profile)
    x_td = float(profile.x_at_jump_length(jump_length))
    p_td = np.array([x_td, lateral, float(profile.z(x_td))])
    t_hat, n_hat = slope.axes(x_td)
    r_td = p_td + clearance * n_hat
    # velocity at the touch-down: a few degrees steeper than the slope
    beta = np.arctan(float(profile.dzdx(x_td)))
    gamma = beta + np.radians(4.5)
    v_td = speed * np.array([np.cos(gamma), 0.0, np.sin(gamma)])
    v_td[1] = lateral_speed
    t_td = 3.0
    t = np.arange(0.0, 6.0 + dt / 2, dt)
    r = np.zeros((t.size, 3))
    fl = t <= t_td
    tau = t[fl] - t_td
    g = np.array([0.0, 0.0, g_eff])
    r[fl] = r_td + v_td * tau[:, None] + 0.5 * g * tau[:, None] ** 2
    # after the touch-down: along the profile at constant speed, sinking onto it
    after = ~fl
    tau = t[after] - t_td
    s = jump_length + speed * np.cos(gamma - beta) * tau
    x = np.asarray(profile.x_at_jump_length(s), dtype=float)
    _, n_a = slope.axes(x)
    # cubic Hermite from (clearance, -v_n) to (0, 0) over 0.3 s: C1 at the touch-down
    v_n = speed * np.sin(gamma - beta)
    u = np.clip(tau / 0.3, 0.0, 1.0)
    d = clearance * (2 * u**3 - 3 * u**2 + 1) - 0.3 * v_n * (u**3 - 2 * u**2 + u)
    y = lateral + lateral_speed * tau
    r[after] = np.stack((x, y, np.asarray(profile.z(x), dtype=float)), -1) + d[:, None] * n_a
    return Trajectory(t, r, t_td)


def trajectory_from_truth(truth: object, meta: dict) -> Trajectory:
    """The landing trajectory of a ``simulate skijump`` truth table.

    Parameters
    ----------
    truth : pyarrow.Table
        Truth table with ``t`` [s] and ``true_x true_y true_z`` (hill frame) [m].
    meta : dict
        Its metadata; the touch-down time is the ``touchdown`` event.

    Raises
    ------
    InputError
        Missing columns or no touch-down event.
    """
    from sportfusion.core import schema

    schema.require_columns(truth, ["t", "true_x", "true_y", "true_z"], "rendering the landing")  # type: ignore[arg-type]
    t = schema.floats(truth, "t")  # type: ignore[arg-type]
    r = schema.float_columns(truth, ("true_x", "true_y", "true_z"))  # type: ignore[arg-type]
    events = [e for e in (meta.get("events") or []) if isinstance(e, dict) and e.get("name") == "touchdown"]
    if not events:
        raise InputError("the truth has no touch-down event; expected a simulated ski jump")
    return Trajectory(t, r, float(events[0]["t"]))


def render_simulated(
    path: str | Path, truth: object, truth_meta: dict, profile: Profile, opts: RenderOptions, progress: object = None
) -> dict:
    """Render a simulated jump's landing and write its marker CSV beside the video.

    Parameters
    ----------
    path : str or Path
        Output video (``landing.mp4``); the markers go to ``landing.markers.csv``.
    truth : pyarrow.Table
        ``simulate skijump`` truth table.
    truth_meta : dict
        Its metadata (the ``touchdown`` event).
    profile : Profile
        The hill's landing profile.
    opts : RenderOptions
    progress : callable, optional
        ``progress(iterable, length, label)`` wrapping the frame loop.

    Returns
    -------
    dict
        The video's truth (:meth:`RenderResult.summary`) with the file names.
    """
    from sportfusion.skijump.video.markers import markers_path_for, write_markers

    res = render_landing(path, trajectory_from_truth(truth, truth_meta), profile, opts, progress)
    mpath = markers_path_for(path)
    write_markers(mpath, res.markers)
    return {"file": str(path), "markers": str(mpath), **res.summary()}
