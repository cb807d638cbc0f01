"""DMC attitude per sample (skiracing-splines eqs 8-9, Table 2): references, QUEST, the dip from data.

The digital-magnetic-compass references: ``m^l`` from a magnetic model and
``f^l = r'' + (2 Omega_ie + Omega_el) r' - g^l`` [m/s^2] (:func:`reference_specific_force`, with
:func:`coriolis_ned`); :func:`dmc_attitude` solves Wahba's problem per sample with
:func:`sportfusion.estimators.quest.quest` from the body magnetometer and specific force;
:func:`gyro_dmc_attitude` is the gyro-stabilised alternative the paper recommends for high
dynamics: the same two vector observations over the whole record, tied together by a gyroscope
(:func:`sportfusion.estimators.attitude_ekf.gyro_vector_smoother`);
:func:`dip_from_quiet` estimates the inclination [rad] from quiet samples; :func:`lowpass` is the
zero-phase Butterworth filter [Hz] applied to the sensors first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core.rotations import dcm_from_quat, euler_from_dcm
from sportfusion.core.stats import median
from sportfusion.estimators.quest import _unit, quest

#: Earth rotation rate [rad/s] (WGS84)
OMEGA_EARTH = 7.292115e-5


_A = 6378137.0


_E2 = 0.00669437999013


def coriolis_ned(vel_ned: np.ndarray, lat_deg: float, h: float = 0.0) -> np.ndarray:
    """``(2 Omega_ie + Omega_el) v`` of eq 9 in NED [m/s^2] for velocities ``(N, 3)`` [m/s].

    ``omega_ie = w_e [cos phi, 0, -sin phi]``; transport rate
    ``omega_el = [v_e/(R_N+h), -v_n/(R_M+h), -v_e tan(phi)/(R_N+h)]``.
    """
    v = np.asarray(vel_ned, float)
    phi = np.deg2rad(lat_deg)
    s = np.sin(phi)
    rn = _A / np.sqrt(1 - _E2 * s * s)
    rm = _A * (1 - _E2) / (1 - _E2 * s * s) ** 1.5
    w_ie = OMEGA_EARTH * np.array([np.cos(phi), 0.0, -s])
    w_el = np.stack((v[:, 1] / (rn + h), -v[:, 0] / (rm + h), -v[:, 1] * np.tan(phi) / (rn + h)), axis=-1)
    return np.cross(2 * w_ie + w_el, v)


def reference_specific_force(
    acc_ned: np.ndarray | None,
    g: float,
    n: int | None = None,
    vel_ned: np.ndarray | None = None,
    lat_deg: float | None = None,
    h: float = 0.0,
) -> np.ndarray:
    """Eq 9: ``f^l = r'' + (2 Omega_ie + Omega_el) r' - g^l`` in NED [m/s^2].

    Parameters
    ----------
    acc_ned : array (N, 3) or None
        Kinematic acceleration [m/s^2] (from the GNSS spline); None means low
        dynamics (``f^l = -g^l = [0, 0, -g]``), and ``n`` gives the count.
    g : float
        Gravity magnitude [m/s^2]; ``g^l = [0, 0, g]`` (down).
    vel_ned, lat_deg, h : optional
        Velocity [m/s], latitude [deg] and height [m] for the Coriolis and
        transport terms; omitted when ``vel_ned`` is None.
    """
    if acc_ned is None:
        f = np.zeros((int(n or 0), 3))
    else:
        f = np.array(acc_ned, dtype=float, copy=True)
    if vel_ned is not None and lat_deg is not None:
        f = f + coriolis_ned(vel_ned, lat_deg, h)
    f[:, 2] -= g
    return f


@dataclass
class DMCResult:
    """Per-sample DMC/GNSS attitude (:func:`dmc_attitude`).

    Attributes
    ----------
    q : (N, 4) ``q_BO`` scalar first.
    roll, pitch, yaw : (N,) [rad]; yaw is the azimuth from north.
    loss : (N,) Wahba loss (``quest_loss``), dimensionless.
    singular : (N,) bool, the reference or measured specific force is near
        free fall, or the two directions are nearly parallel.
    acc_kin_ned : (N, 3) kinematic acceleration re-estimated from the measured
        specific force through the attitude (eq 9 solved for ``r''``) [m/s^2].
    bias_gyr : (N, 3) estimated gyro bias [rad/s] (:func:`gyro_dmc_attitude` only, else None).
    std_rpy : (N, 3) 1-sigma of roll, pitch, yaw [rad] (:func:`gyro_dmc_attitude` only, else None).
    iterations : Gauss-Newton iterations of :func:`gyro_dmc_attitude` (0 for the DMC alone).
    converged : whether those iterations converged (True for the DMC alone).
    bias_mag : (3,) estimated magnetometer hard-iron bias, body frame [unit of the magnetometer]
        (:func:`gyro_dmc_attitude` with ``sigma_mag_bias > 0`` only, else None).
    std_bias_mag : (3,) its 1-sigma [unit of the magnetometer], or None.
    bias_acc, std_bias_acc : (3,) estimated accelerometer bias, body frame, and its 1-sigma [m/s^2]
        (:func:`gyro_dmc_attitude` with ``sigma_acc_bias > 0`` only, else None).
    """

    q: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    loss: np.ndarray
    singular: np.ndarray
    acc_kin_ned: np.ndarray
    bias_gyr: np.ndarray | None = None
    std_rpy: np.ndarray | None = None
    iterations: int = 0
    converged: bool = True
    bias_mag: np.ndarray | None = None
    std_bias_mag: np.ndarray | None = None
    bias_acc: np.ndarray | None = None
    std_bias_acc: np.ndarray | None = None


def kinematic_acceleration(
    M: np.ndarray, f_body: np.ndarray, g: float, coriolis: np.ndarray | None = None
) -> np.ndarray:
    """Eq 9 solved for ``r''``: ``M_BO^T f^b + g^l - (2 Omega_ie + Omega_el) v`` in NED [m/s^2].

    ``M`` (N, 3, 3) the attitude's ``M_BO``, ``f_body`` (N, 3) [m/s^2], ``g`` [m/s^2], ``coriolis``
    (N, 3) [m/s^2] or None.
    """
    acc = np.einsum("nji,nj->ni", M, f_body)  # M_BO^T f^b: specific force in NED
    acc[:, 2] += g
    return acc - coriolis if coriolis is not None else acc


def dmc_attitude(
    acc_body: np.ndarray,
    mag_body: np.ndarray,
    f_ref_ned: np.ndarray,
    m_ref_ned: np.ndarray,
    g: float,
    *,
    weight_acc: float = 1.0,
    weight_mag: float = 1.0,
    free_fall: float = 2.0,
    min_angle_deg: float = 5.0,
    coriolis: np.ndarray | None = None,
) -> DMCResult:
    """Instantaneous 3D attitude from a 3-axis DMC and GNSS (Table 2, eqs 8-9).

    Parameters
    ----------
    acc_body : (N, 3) measured specific force [m/s^2].
    mag_body : (N, 3) measured magnetic field (uT or normalised; only the direction is used).
    f_ref_ned : (N, 3) reference specific force in NED [m/s^2] (:func:`reference_specific_force`).
    m_ref_ned : (3,) or (N, 3) reference magnetic field in NED (any unit).
    g : float, gravity [m/s^2] (to re-estimate the kinematic acceleration).
    weight_acc, weight_mag : relative weights of the two observations.
    free_fall : float [m/s^2]; ``|f|`` below this (reference or measured) flags the sample singular.
    min_angle_deg : float [deg]; a reference or measured angle between f and m
        below this (or above 180 minus it) flags the sample singular.
    coriolis : (N, 3) optional, the ``(2 Omega_ie + Omega_el) v`` term [m/s^2]
        removed when re-estimating the kinematic acceleration.
    """
    f_b = np.asarray(acc_body, float)
    m_b = np.asarray(mag_body, float)
    f_l = np.asarray(f_ref_ned, float)
    m_l = np.broadcast_to(np.asarray(m_ref_ned, float), f_l.shape)
    body = np.stack((f_b, m_b), axis=1)
    ref = np.stack((f_l, m_l), axis=1)
    q, loss = quest(body, ref, np.array([weight_acc, weight_mag]))
    M = dcm_from_quat(q)  # one DCM for the Euler angles and the re-estimated acceleration
    roll, pitch, yaw = euler_from_dcm(M)
    sin2_min = np.sin(np.deg2rad(min_angle_deg)) ** 2

    def norm2(u: np.ndarray) -> np.ndarray:
        return np.einsum("...i,...i->...", u, u)

    def sin2_angle(u: np.ndarray, v: np.ndarray, uu: np.ndarray, vv: np.ndarray) -> np.ndarray:
        """sin^2 of the angle between u and v: 1 - cos^2, from the squared norms uu, vv."""
        uv = np.einsum("...i,...i->...", u, v)
        return 1.0 - uv * uv / (uu * vv)

    with np.errstate(invalid="ignore", divide="ignore"):
        ffl, ffb, mml, mmb = norm2(f_l), norm2(f_b), norm2(np.asarray(m_ref_ned, float)), norm2(m_b)
        singular = (
            (ffl < free_fall**2)
            | (ffb < free_fall**2)
            | (sin2_angle(f_l, m_l, ffl, mml) < sin2_min)
            | (sin2_angle(f_b, m_b, ffb, mmb) < sin2_min)
        )
    return DMCResult(q, roll, pitch, yaw, loss, singular, kinematic_acceleration(M, f_b, g, coriolis))


def bridge_with_gyro(q: np.ndarray, bad: np.ndarray, t: np.ndarray, gyr: np.ndarray) -> np.ndarray:
    """Attitudes ``q_BO`` (N, 4) with the ``bad`` rows replaced by the gyro integrated from the last good row.

    Leading bad rows take the first good row's attitude; ``gyr`` (N, 3) [rad/s] follows
    :func:`sportfusion.core.rotations.integrate_body_rates` (row k: mean rate over the interval ending
    at ``t[k]`` [s]).  All rows bad: ``q`` unchanged.
    """
    from sportfusion.core.rotations import integrate_body_rates

    q = np.array(q, dtype=float, copy=True)
    bad = np.asarray(bad, bool)
    good = np.flatnonzero(~bad)
    if good.size == 0 or good.size == bad.size:
        return q
    q[: good[0]] = q[good[0]]
    edges = np.diff(np.r_[0, bad[good[0] :].astype(np.int8), 0])
    starts = np.flatnonzero(edges == 1) + good[0]
    ends = np.flatnonzero(edges == -1) + good[0]
    for s, e in zip(starts, ends, strict=True):
        q[s - 1 : e] = integrate_body_rates(q[s - 1], t[s - 1 : e], gyr[s - 1 : e])
    return q


def euler_std(q: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """1-sigma of roll, pitch, yaw [rad] (N, 3) from the covariance (N, 3, 3) [rad^2] of the body-frame
    attitude error ``dtheta`` (``q_true = q ⊗ Exp(dtheta)``), through the Euler angles' Jacobian
    (central differences of 1e-6 rad)."""
    from sportfusion.core.rotations import euler_from_quat, quat_from_rotvec, quat_multiply

    eps = 1e-6
    J = np.empty((q.shape[0], 3, 3))
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        plus = np.array(euler_from_quat(quat_multiply(q, quat_from_rotvec(d))))
        minus = np.array(euler_from_quat(quat_multiply(q, quat_from_rotvec(-d))))
        J[:, :, i] = (np.angle(np.exp(1j * (plus - minus)))).T / (2 * eps)  # yaw/roll wrap at +-pi
    return np.sqrt(np.maximum(np.einsum("nij,njk,nik->ni", J, cov, J), 0.0))


def gyro_dmc_attitude(
    t: np.ndarray,
    acc_body: np.ndarray,
    mag_body: np.ndarray,
    gyr_body: np.ndarray,
    f_ref_ned: np.ndarray,
    m_ref_ned: np.ndarray,
    g: float,
    *,
    dmc: DMCResult,
    sigma_acc: float = 0.5,
    acc_mismatch: float = 1.0,
    sigma_mag: float = 0.02,
    gyro_noise: float = 3e-4,
    bias_walk: float = 2e-4,
    sigma_bias0: float = 0.05,
    sigma_mag_bias: float = 0.0,
    sigma_acc_bias: float = 0.0,
    lat_deg: float | None = None,
    coriolis: np.ndarray | None = None,
    reference_ok: np.ndarray | None = None,
    acc_sigma_rows: np.ndarray | None = None,
) -> DMCResult:
    """Gyro-stabilised DMC attitude: the specific force and the field of every sample, tied by the gyroscope.

    The skiracing-splines paper finds the per-sample DMC "several degrees" worse in high dynamics
    and names gyro-stabilised magnetometers the better choice.  Here the gyro carries the attitude
    from sample to sample and the two DMC vectors correct it, all samples at once
    (:func:`sportfusion.estimators.attitude_ekf.gyro_vector_smoother`, the gyro bias estimated along):

    * specific force: ``f^b = M_BO f^l + v`` [m/s^2] with isotropic 1-sigma
      ``sqrt(sigma_acc^2 + (acc_mismatch (|f^b| - |f^l|))^2)``: a sample whose measured and reference
      lengths disagree (vibration, an impact, a GNSS acceleration the spline smoothed away) counts
      less, and near free fall both vectors are short, so it carries no tilt, as it should;
    * magnetic field: the unit vectors ``m^b/|m^b| = M_BO m^l/|m^l|`` with 1-sigma ``sigma_mag`` [rad]
      (only the direction is used, as by QUEST: uT and normalised magnetometers give one answer);
      with ``sigma_mag_bias > 0`` the magnetometer's constant hard-iron bias ``b_m`` is estimated
      along (``(m^b - b_m)/|m^b - b_m| = M_BO m^l/|m^l|``, ``b_m`` in the body frame and the
      magnetometer's unit, Gaussian prior ``N(0, sigma_mag_bias^2 I)``; the smoother's ``obs_bias``):
      the rotations of the run make it observable, and the standing start benefits too.

    The starting trajectory is the per-sample DMC (``dmc``, :func:`dmc_attitude`) with its singular
    rows, and those without a usable reference, bridged by the gyro (:func:`bridge_with_gyro`).

    Parameters
    ----------
    t : (N,) [s], strictly increasing.
    acc_body, mag_body : (N, 3) specific force [m/s^2] and field (any unit) in the body frame.
    gyr_body : (N, 3) body rate [rad/s]; row k the mean rate over the interval ending at ``t[k]``.
    f_ref_ned : (N, 3) reference specific force [m/s^2]; m_ref_ned : (3,) reference field (any unit).
    g : gravity [m/s^2] (to re-estimate the kinematic acceleration).
    dmc : the per-sample DMC solution on the same rows (start, ``quest_loss`` and singular flags).
    sigma_acc : [m/s^2]; acc_mismatch : [1]; sigma_mag : [rad].
    gyro_noise : [rad/s/sqrt(Hz)] white noise density; bias_walk : [rad/s/sqrt(s)]; sigma_bias0 : prior
        1-sigma of the bias [rad/s].
    sigma_mag_bias : prior 1-sigma per axis of the magnetometer's hard-iron bias [unit of ``mag_body``];
        0: not estimated (the field's direction as measured).
    sigma_acc_bias : prior 1-sigma per axis of the accelerometer's bias [m/s^2] (``f^b - b_a = M_BO f^l``),
        estimated along; 0: not estimated.
    lat_deg : latitude [deg] for the Earth rate the gyro also measures (None: left in).
    coriolis : (N, 3) optional ``(2 Omega_ie + Omega_el) v`` [m/s^2] for the re-estimated acceleration.
    reference_ok : (N,) bool, rows whose reference specific force is known (a GNSS acceleration, or a
        quiet sample under the low-dynamics assumption); the others use no specific force (the gyro
        and the field carry the attitude there).  None: all.
    acc_sigma_rows : (N,) extra 1-sigma [m/s^2] per row, added in quadrature to the specific force's (the
        accelerations a low-dynamics reference ``f = -g`` ignores on a walk), or None.

    Returns
    -------
    DMCResult
        With ``bias_gyr``, ``std_rpy``, ``iterations`` (and ``bias_mag``, ``std_bias_mag`` when estimated);
        ``loss`` and ``singular`` are the per-sample DMC's.

    Raises
    ------
    ValueError
        When the smoother's normal equations are not positive definite (no usable observation at all).
    """
    from sportfusion.core.rotations import dcm_from_quat
    from sportfusion.estimators.attitude_ekf import gyro_vector_smoother

    f_b = np.asarray(acc_body, float)
    f_l = np.asarray(f_ref_ned, float)
    estimate_mag_bias = sigma_mag_bias > 0
    m_b = np.asarray(mag_body, float) if estimate_mag_bias else _unit(np.asarray(mag_body, float))
    m_l = np.broadcast_to(_unit(np.asarray(m_ref_ned, float)), f_l.shape)
    mismatch = np.linalg.norm(f_b, axis=1) - np.linalg.norm(f_l, axis=1)
    s_acc = np.sqrt(sigma_acc**2 + (acc_mismatch * mismatch) ** 2)
    if acc_sigma_rows is not None:
        s_acc = np.sqrt(s_acc**2 + np.asarray(acc_sigma_rows, float) ** 2)
    if reference_ok is not None:
        s_acc = np.where(np.asarray(reference_ok, bool), s_acc, np.inf)  # non-finite: not observed
    sigma = np.column_stack((s_acc, np.full(s_acc.shape, float(sigma_mag))))
    w_ie = None
    if lat_deg is not None:
        phi = np.deg2rad(lat_deg)
        w_ie = OMEGA_EARTH * np.array([np.cos(phi), 0.0, -np.sin(phi)])
    bad = dmc.singular | ~np.isfinite(dmc.q[:, 0]) | ~np.isfinite(s_acc)
    q_init = bridge_with_gyro(dmc.q, bad, t, gyr_body)
    res = gyro_vector_smoother(
        t,
        gyr_body,
        np.stack((f_b, m_b), axis=1),
        np.stack((f_l, m_l), axis=1),
        sigma,
        q_init[0],
        sigma_q0=0.2,
        sigma_bias0=sigma_bias0,
        gyro_noise=gyro_noise,
        bias_walk=bias_walk,
        w_ie_ned=w_ie,
        names=("specific_force", "magnetic_field"),
        q_init=q_init,
        obs_bias={i: s for i, s in ((0, float(sigma_acc_bias)), (1, float(sigma_mag_bias))) if s > 0},
        direction=(1,) if estimate_mag_bias else (),
    )
    M = dcm_from_quat(res.q)
    roll, pitch, yaw = euler_from_dcm(M)
    std = euler_std(res.q, res.cov_theta)
    return DMCResult(
        res.q,
        roll,
        pitch,
        yaw,
        dmc.loss,
        dmc.singular,
        kinematic_acceleration(M, f_b, g, coriolis),
        bias_gyr=res.bias,
        std_rpy=std,
        iterations=res.iterations,
        converged=res.converged,
        bias_mag=res.obs_bias.get(1),
        std_bias_mag=res.std_obs_bias.get(1),
        bias_acc=res.obs_bias.get(0),
        std_bias_acc=res.std_obs_bias.get(0),
    )


def dip_from_quiet(
    acc_body: np.ndarray, mag_body: np.ndarray, g: float, fs: float, window_s: float = 1.0, tol: float = 0.3
) -> tuple[float, int]:
    """Magnetic inclination [deg] estimated from quiet samples.

    In a quiet sample the specific force is ``-g^l`` (pointing up), so the
    angle between the measured field and the measured specific force gives the
    dip: ``sin I = -m̂ · f̂``.  A sample is quiet when ``| |f| - g | < tol`` and
    the moving standard deviation of ``|f|`` over ``window_s`` is below ``tol / 3``.

    Parameters
    ----------
    acc_body, mag_body : (N, 3) specific force [m/s^2] and field (any unit).
    g : float, gravity [m/s^2].
    fs : float, sample rate [Hz].
    window_s : float [s], tol : float [m/s^2].

    Returns
    -------
    inclination_deg : float
        Median over the quiet samples (NaN if none).
    count : int
        Number of quiet samples used.
    """
    f = np.asarray(acc_body, float)
    m = np.asarray(mag_body, float)
    quiet = quiet_mask(f, g, fs, window_s, tol) & np.all(np.isfinite(m), axis=-1)
    if not quiet.any():
        return float("nan"), 0
    s = -np.einsum("ni,ni->n", _unit(m[quiet]), _unit(f[quiet]))
    return float(np.degrees(np.arcsin(median(np.clip(s, -1, 1))))), int(quiet.sum())


def quiet_mask(acc_body: np.ndarray, g: float, fs: float, window_s: float = 1.0, tol: float = 0.3) -> np.ndarray:
    """Quiet samples: ``| |f| - g | < tol`` [m/s^2] and the moving 1-sigma of ``|f|`` over ``window_s`` below ``tol/3``."""
    f = np.asarray(acc_body, float)
    norm = np.linalg.norm(f, axis=-1)
    k = max(int(round(window_s * fs)), 1)
    ok = np.isfinite(norm)
    x = np.where(ok, norm, g)
    kern = np.ones(k) / k
    mean = np.convolve(x, kern, mode="same")
    var = np.convolve(x * x, kern, mode="same") - mean**2
    return ok & (np.abs(norm - g) < tol) & (np.sqrt(np.maximum(var, 0)) < tol / 3)


def lowpass(x: np.ndarray, fs: float, cutoff_hz: float, order: int = 2) -> np.ndarray:
    """Zero-phase Butterworth low-pass of each column of ``x`` (N, d) sampled at ``fs`` [Hz].

    ``cutoff_hz`` >= fs/2 or <= 0 returns ``x`` unchanged.  NaN samples are
    bridged by linear interpolation for filtering and stay NaN in the output.
    """
    from scipy.signal import butter, sosfiltfilt

    x = np.asarray(x, float)
    if cutoff_hz <= 0 or cutoff_hz >= fs / 2 or x.shape[0] < 3 * (2 * order + 1):
        return x.copy()
    sos = butter(order, cutoff_hz, fs=fs, output="sos")
    out = np.empty_like(x)
    idx = np.arange(x.shape[0])
    for c in range(x.shape[1]):
        col = x[:, c]
        ok = np.isfinite(col)
        if not ok.any():
            out[:, c] = col
            continue
        filled = np.interp(idx, idx[ok], col[ok])
        out[:, c] = np.where(ok, sosfiltfilt(sos, filled), np.nan)
    return out


def magnetometer_plausibility(
    f_body: np.ndarray,
    m_body: np.ndarray,
    f_ref: np.ndarray,
    m_ref: np.ndarray,
    norm_ref: float | None = None,
    angle_tol_deg: float = 5.0,
    norm_tol: float = 0.2,
    force_tol: float = 1.0,
    window: int = 1,
    reference_ok: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples whose magnetometer disagrees with the magnetic model (a disturbed or miscalibrated sensor).

    A rotation keeps angles and lengths, so in every sample the angle between
    the measured field and the measured specific force must equal the angle
    between the reference field and the reference specific force (in level,
    unaccelerated samples: 90 deg plus the inclination), and the field norm
    must equal the model's intensity.  The angle is compared only where the
    specific force is trustworthy as a reference: its measured and reference
    lengths agree within ``force_tol`` [m/s^2] (not in free fall, and not in
    motion that the reference does not know, e.g. low dynamics assumed while
    turning).  Both quantities are smoothed by a running median over
    ``window`` samples (vibration and single spikes are not a disturbed
    sensor); a sample is implausible when the angle differs by more than
    ``angle_tol_deg`` or the norm by more than ``norm_tol`` (relative).

    Parameters
    ----------
    f_body, m_body : (N, 3) specific force [m/s^2] and field (body frame).
    f_ref : (N, 3) or (3,) reference specific force [m/s^2]; m_ref : (3,) reference field (NED, any unit).
    norm_ref : field intensity in the unit of ``m_body`` (None: the median of ``|m_body|``, which then
        tests the norm's steadiness only, for normalised or uncalibrated units).
    angle_tol_deg : [deg]; norm_tol : [1]; force_tol : [m/s^2]; window : running-median length [samples].
    reference_ok : (N,) bool, rows whose reference specific force is known (GNSS acceleration, or a quiet
        sample under the low-dynamics assumption); None: all.

    Returns
    -------
    flag : (N,) bool
    angle_error_deg : (N,) measured minus reference angle between field and specific force [deg], smoothed
        (NaN where the specific force is not a usable reference)
    norm_ratio : (N,) ``|m| / norm_ref`` [1], smoothed
    """
    from scipy.ndimage import median_filter

    f = np.asarray(f_body, float)
    m = np.asarray(m_body, float)
    fr = np.broadcast_to(np.asarray(f_ref, float), f.shape)
    mr = np.asarray(m_ref, float)
    cos_meas = np.clip(np.einsum("ni,ni->n", _unit(m), _unit(f)), -1, 1)
    cos_ref = np.clip(_unit(fr) @ _unit(mr[None, :])[0], -1, 1)
    err = np.degrees(np.arccos(cos_meas) - np.arccos(cos_ref))
    usable = np.isfinite(err) & (np.abs(np.linalg.norm(f, axis=1) - np.linalg.norm(fr, axis=1)) < force_tol)
    if reference_ok is not None:
        usable &= np.asarray(reference_ok, bool)
    size = max(1, int(window)) | 1
    err_s = np.full(err.shape, np.nan)
    if usable.any():
        err_s[usable] = median_filter(err[usable], size=size, mode="nearest")
    mn = np.linalg.norm(m, axis=1)
    ref = float(np.nanmedian(mn)) if norm_ref is None else float(norm_ref)
    ratio = median_filter(mn, size=size, mode="nearest") / ref if ref > 0 else np.full(mn.shape, np.nan)
    flag = (np.abs(np.nan_to_num(err_s)) > angle_tol_deg) | (np.abs(ratio - 1.0) > norm_tol)
    return flag, err_s, ratio
