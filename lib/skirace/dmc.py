"""DMC/GNSS attitude over a session table (what ``dmc-attitude`` does).

Rows: the attitude is computed on every row with a complete specific-force
sample (``acc_x acc_y acc_z``).  The magnetometer is used on the same rows;
where it sampled at other instants it is interpolated linearly onto the
accelerometer rows.  GNSS kinematic acceleration ``ax ay az`` (from
``spline-smooth``, in the session's local frame) is taken on those rows, and
interpolated from the neighbouring rows where it is null; rows with none
(before/after GNSS coverage) fall back to low dynamics (``f^l = -g``).

With a gyroscope (``gyr_x gyr_y gyr_z`` [rad/s], interpolated onto the
accelerometer rows like the magnetometer) the attitude is gyro-stabilised
(:func:`sportfusion.skirace.attitude.gyro_dmc_attitude`: the same two vector
observations on every row, tied together by the gyro, its bias estimated
along) unless ``use_gyro`` is False; ``info["method"]`` says which ran
(``gyro+dmc`` or ``dmc``).  The gyro-stabilised attitude adds
``bias_gyr_x bias_gyr_y bias_gyr_z`` [rad/s] and ``std_roll std_pitch
std_yaw`` [rad], and, with ``sigma_mag_bias > 0`` (the default), the
magnetometer's hard-iron bias estimated along, ``bias_mag_x bias_mag_y
bias_mag_z`` with ``std_bias_mag_*`` [the magnetometer's unit; one value
repeated on every attitude row], and the accelerometer's, ``bias_acc_*`` with
``std_bias_acc_*`` [m/s^2] (``sigma_acc_bias > 0``, the default); ``quest_loss`` and ``dmc_singular`` stay the
per-sample DMC's.  A gyro that does not cover every attitude row falls back to the DMC
alone, with a warning.

Frames: local vectors are rotated to NED by :func:`sportfusion.core.rotations.local_to_ned`
with the frame's azimuth before the reference vectors are formed; the
attitude ``q_BO`` and ``yaw`` refer to NED (yaw is the azimuth from north);
the re-estimated kinematic acceleration ``ax_dmc ay_dmc az_dmc`` is returned
in the local frame, comparable with ``ax ay az``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.gravity import G_STANDARD, normal_gravity
from sportfusion.core.magfield import field_from_angles, inclination_declination, reference_field
from sportfusion.core.rotations import interval_mean_rates, local_to_ned, ned_to_local
from sportfusion.core.stats import median
from sportfusion.skirace.attitude import (
    coriolis_ned,
    dip_from_quiet,
    dmc_attitude,
    gyro_dmc_attitude,
    lowpass,
    magnetometer_plausibility,
    quiet_mask,
    reference_specific_force,
)

#: gyro rows slower than this [Hz] cannot carry the attitude from sample to sample (a 1 Hz phone log turns
#: by tens of degrees between samples): the DMC alone
MIN_GYRO_RATE = 10.0
#: 1-sigma [m/s^2] of the low-dynamics reference f = -g on rows without a GNSS acceleration that are not
#: quiet: a walker's or skier's own accelerations (a walk's steps: 1-2 m/s^2, a ski turn's several), which
#: average out over the seconds the gyro holds the attitude.  Without it such rows had no tilt reference and
#: on a walk the attitude turned about the field's direction unseen (8 deg off a phone's own fusion); on the
#: simulated ski runs without GNSS (seeds 1-5) it takes the run's median error from 0.64-4.10 to 0.54-1.33 deg
#: and leaves the standing start at 0.18-0.90 deg (0.18-0.76 before)
SIGMA_LOW_DYNAMICS = 10.0
#: the gyro-stabilised attitude is rejected (the DMC alone kept) when its median angle to the per-sample DMC,
#: where the DMC's reference is sound, exceeds this [deg]: it has not converged to the truth
MAX_DMC_DISAGREEMENT = 10.0
#: the measured field may be this far [deg] from the reference rotated by the gyro solution, in the median
MAX_FIELD_RESIDUAL = 10.0
#: the mean specific force over 20 s, rotated into NED by the gyro solution, may point this far [deg] from up
MAX_TILT_RESIDUAL = 15.0
#: the default low-pass cut-off [Hz], applied when the rows are faster than twice it
DEFAULT_LOWPASS = 5.0


@dataclass
class DMCSessionResult:
    """Columns to add (name -> array, NaN/null where a row has no attitude), plus what happened."""

    columns: dict[str, np.ndarray | pa.Array]
    rows: np.ndarray  # bool, rows with an attitude
    info: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def _fill(t: np.ndarray, x: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Values of ``x`` (N, 3; NaN where missing) at ``rows``, linearly interpolated inside the data's span."""
    out = np.full((rows.size, x.shape[1]), np.nan)
    ok = np.all(np.isfinite(x), axis=1)
    if ok.sum() < 2:
        out[:] = x[rows] if ok.sum() else np.nan
        return out
    tr = t[rows]
    inside = (tr >= t[ok][0]) & (tr <= t[ok][-1])
    for c in range(x.shape[1]):
        out[inside, c] = np.interp(tr[inside], t[ok], x[ok, c])
    return out


def dmc_session(
    t: np.ndarray,
    acc: np.ndarray,
    mag: np.ndarray,
    *,
    acc_kin: np.ndarray | None = None,
    vel: np.ndarray | None = None,
    azimuth_deg: float = 0.0,
    site: tuple[float, float, float] | None = None,
    when: float | str | None = None,
    mag_ref: np.ndarray | None = None,
    dip_from_data: bool = False,
    g0: float | None = None,
    weight_acc: float = 1.0,
    weight_mag: float = 1.0,
    lowpass_hz: float | None = None,
    coriolis: bool = False,
    free_fall: float = 2.0,
    mag_unit: str | None = "uT",
    dip_tol: float = 5.0,
    angle_tol: float = 5.0,
    norm_tol: float = 0.2,
    gyr: np.ndarray | None = None,
    use_gyro: bool = True,
    gyro_samples: str = "mean",
    sigma_acc: float = 0.5,
    sigma_mag: float = 0.02,
    gyro_noise: float = 3e-4,
    bias_walk: float = 2e-4,
    sigma_mag_bias: float = 0.5,
    sigma_acc_bias: float = 0.05,
) -> DMCSessionResult:
    """Attitude per IMU row of a session from a DMC and the GNSS acceleration.

    Parameters
    ----------
    t : (N,) row times [s].
    acc : (N, 3) specific force [m/s^2] in the body frame, NaN where not sampled.
    mag : (N, 3) magnetic field in the body frame (uT or normalised), NaN where not sampled.
    acc_kin : (N, 3) kinematic acceleration in the local frame [m/s^2] (``ax ay az``) or None.
    vel : (N, 3) velocity in the local frame [m/s] (for ``coriolis``) or None.
    azimuth_deg : the local frame's x-axis azimuth [deg].
    site : (lat [deg], lon [deg], h [m]) for gravity and the magnetic model.
    when : date of the session (Unix seconds or ISO-8601) for the magnetic model.
    mag_ref : (3,) reference field in NED (any unit) overriding the model.
    dip_from_data : estimate the inclination from quiet samples instead of the model
        (declination from the model when site and date are known, else 0).
    g0 : gravity [m/s^2] overriding normal gravity.
    weight_acc, weight_mag : Wahba weights of the two observations.
    lowpass_hz : zero-phase low-pass of the raw DMC channels [Hz] (0: none; None: ``DEFAULT_LOWPASS``, 5 Hz,
        left out with a note on rows slower than 10 Hz, e.g. a 1 Hz phone log).
    coriolis : include the Coriolis and transport terms of eq 9 (needs ``vel`` and ``site``).
    free_fall : |f| below this [m/s^2] flags ``dmc_singular``.
    mag_unit : unit of ``mag`` (``uT``: its norm is compared with the model's intensity; else only its
        steadiness).
    dip_tol : largest difference [deg] between the inclination from the data and the model's before a warning.
    angle_tol, norm_tol : per-sample plausibility limits [deg], [1]
        (:func:`sportfusion.skirace.attitude.magnetometer_plausibility`): the field-to-gravity angle is
        compared with the model's on quiet samples (f = -g known), the field norm with the model's
        intensity on every sample, both over a 1 s running median; flagged samples are in
        ``mag_implausible`` and counted in a warning.
    gyr : (N, 3) body rate [rad/s] (``gyr_x gyr_y gyr_z``), NaN where not sampled, or None.
    use_gyro : fuse ``gyr`` when given (False: the DMC alone, as without a gyro).
    gyro_samples : ``"mean"``: each gyro row is the mean rate over the interval ending at it (a
        delta-angle gyroscope; what ``simulate skirace`` writes); ``"instant"``: the rate at that instant
        (phones, most MEMS loggers), turned into interval means by the trapezoid
        (:func:`sportfusion.core.rotations.interval_mean_rates`) -- read as "mean", an instantaneous
        gyro lags half a sample.
    sigma_acc : 1-sigma of the specific-force observation [m/s^2] (gyro path; inflated by the
        difference of the measured and reference lengths).
    sigma_mag : 1-sigma of the field direction [rad] (gyro path).
    gyro_noise : gyro white-noise density [rad/s/sqrt(Hz)]; bias_walk : bias random walk
        [rad/s/sqrt(s)] (gyro path).
    sigma_mag_bias : prior 1-sigma per axis of the magnetometer's hard-iron bias [uT] (gyro path), estimated
        along; 0: not estimated.  A magnetometer in another unit (``mag_unit`` not ``uT``, e.g. ``1`` when
        normalised) gets it scaled by its median norm over the model's intensity (50 uT assumed without a
        model), and the estimate ``bias_mag_*`` is in that unit (``info["bias_mag_unit"]``).
    sigma_acc_bias : prior 1-sigma per axis of the accelerometer's bias [m/s^2] (gyro path), estimated along
        (``bias_acc_*``) where there is a GNSS acceleration (``acc_kin``; without one the specific force is
        referenced on quiet samples only, which leave its bias unobservable); 0: not estimated.
    """
    t = np.asarray(t, float)
    n = t.size
    warnings: list[str] = []
    rows = np.flatnonzero(np.all(np.isfinite(acc), axis=1))
    if rows.size < 1:
        raise InputError("no row has a complete accelerometer sample (acc_x acc_y acc_z)")
    f_b = np.asarray(acc, float)[rows]
    same = np.all(np.isfinite(mag[rows]), axis=1)
    m_b = np.asarray(mag, float)[rows].copy()
    if not same.all():
        interp = _fill(t, np.asarray(mag, float), rows)
        m_b[~same] = interp[~same]
    good = np.all(np.isfinite(m_b), axis=1)
    if not good.any():
        raise InputError("no accelerometer row has a magnetometer sample (mag_x mag_y mag_z) at or around it")
    if not good.all():
        warnings.append(f"{int((~good).sum())} accelerometer row(s) have no magnetometer sample around them: left null")
    rows, f_b, m_b = rows[good], f_b[good], m_b[good]
    dt = np.diff(t[rows])
    fs = 1.0 / float(median(dt)) if dt.size else 1.0
    if lowpass_hz is None:
        lowpass_hz = DEFAULT_LOWPASS if DEFAULT_LOWPASS < fs / 2 else 0.0
        if lowpass_hz == 0.0:
            warnings.append(
                f"the rows are at {fs:.3g} Hz: the default {DEFAULT_LOWPASS:g} Hz low-pass is above their Nyquist "
                "frequency and is not applied"
            )
    if lowpass_hz >= fs / 2:
        raise InputError(
            f"low-pass cut-off {lowpass_hz:g} Hz is at or above the Nyquist frequency {fs / 2:.4g} Hz of the "
            "accelerometer rows; expected a lower cut-off (or 0: none)"
        )
    if lowpass_hz > 0:
        f_b = lowpass(f_b, fs, lowpass_hz)
        m_b = lowpass(m_b, fs, lowpass_hz)
    # gravity
    if g0 is not None:
        g = float(g0)
    elif site is not None:
        g = float(normal_gravity(site[0], site[2]))
    else:
        g = G_STANDARD
        warnings.append(f"no site: gravity is the standard {G_STANDARD} m/s^2")
    # magnetic reference in NED
    info: dict = {"gravity": g}
    model = None
    if site is not None and when is not None:
        model = reference_field(site[0], site[1], site[2], when)
    if mag_ref is not None:
        m_ref = np.asarray(mag_ref, float)
        src = "given"
    else:
        if dip_from_data:
            inc, count = dip_from_quiet(f_b, m_b, g, fs)
            if count == 0:
                raise InputError(
                    "--dip-from-data found no quiet samples (|f| within 0.3 m/s^2 of g and steady for 1 s)"
                )
            dec = inclination_declination(model)[1] if model is not None else 0.0
            if model is None:
                warnings.append("no site/date for the declination: yaw is the magnetic azimuth")
            m_ref = field_from_angles(inc, dec)
            src = f"dip from {count} quiet samples"
            if model is not None:
                inc_model = inclination_declination(model)[0]
                info["inclination_model_deg"] = inc_model
                if abs(inc - inc_model) > dip_tol:
                    warnings.append(
                        f"--dip-from-data: measured inclination {inc:.1f} deg vs {inc_model:.1f} deg from the World "
                        f"Magnetic Model at the site ({inc - inc_model:+.1f} deg, more than {dip_tol:g}): the "
                        "magnetometer is disturbed or miscalibrated and the attitude tilts with it; implausible "
                        "samples are flagged in mag_implausible"
                    )
        elif model is not None:
            m_ref = model
            src = "World Magnetic Model"
        else:
            raise InputError(
                "the magnetic reference needs a site and a date (lat/lon columns or frame origin, time.epoch_utc), "
                "or --site/--date, --mag-ref N,E,D or --dip-from-data"
            )
    inc, dec = inclination_declination(m_ref)
    info.update({"mag_ref_source": src, "inclination_deg": inc, "declination_deg": dec})
    # reference specific force
    low_dyn = np.ones(rows.size, bool)  # rows under the low-dynamics assumption
    if acc_kin is None:
        warnings.append("no GNSS acceleration (ax ay az; run spline-smooth first): assuming low dynamics, f = -g")
        a_loc = np.zeros((rows.size, 3))
    else:
        a_loc = _fill(t, np.asarray(acc_kin, float), rows)
        low_dyn = ~np.all(np.isfinite(a_loc), axis=1)
        if low_dyn.any():
            warnings.append(f"{int(low_dyn.sum())} row(s) outside the GNSS acceleration: assuming low dynamics there")
            a_loc[low_dyn] = 0.0
    a_ned = local_to_ned(a_loc, azimuth_deg)
    cor = None
    if coriolis:
        if vel is None or site is None:
            warnings.append("--coriolis needs vx vy vz and a site: Coriolis terms left out")
        else:
            v_loc = _fill(t, np.asarray(vel, float), rows)
            v_loc[~np.all(np.isfinite(v_loc), axis=1)] = 0.0
            cor = coriolis_ned(local_to_ned(v_loc, azimuth_deg), site[0], site[2])
    f_ref = reference_specific_force(a_ned, g)
    if cor is not None:
        f_ref = f_ref + cor
    res = dmc_attitude(
        f_b, m_b, f_ref, m_ref, g, weight_acc=weight_acc, weight_mag=weight_mag, free_fall=free_fall, coriolis=cor
    )
    method = "dmc"
    if gyr is not None and use_gyro:
        w_b = np.asarray(gyr, float)[rows].copy()
        miss = ~np.all(np.isfinite(w_b), axis=1)
        if miss.any():
            w_b[miss] = _fill(t, np.asarray(gyr, float), rows)[miss]
        if gyro_samples not in ("mean", "instant"):
            raise InputError(f"gyro samples {gyro_samples!r}; expected mean or instant")
        uncovered = int((~np.all(np.isfinite(w_b), axis=1)).sum())
        if uncovered:
            warnings.append(
                f"the gyroscope (gyr_x gyr_y gyr_z) does not cover {uncovered} of {rows.size} attitude row(s): "
                "attitude from the DMC alone"
            )
        elif rows.size < 2:
            warnings.append("one attitude row: attitude from the DMC alone")
        elif fs < MIN_GYRO_RATE:
            warnings.append(
                f"the rows are at {fs:.3g} Hz, too slow for the gyroscope to carry the attitude from one sample to "
                f"the next (it needs {MIN_GYRO_RATE:g} Hz or more): attitude from the DMC alone"
            )
        else:
            if gyro_samples == "instant":
                w_b = interval_mean_rates(w_b)
            s_bias = float(sigma_mag_bias)
            bias_unit = mag_unit or "uT"
            if s_bias > 0 and bias_unit != "uT":
                # the prior [uT] in the magnetometer's unit: its median norm stands for the field's intensity
                if model is not None:
                    intensity = float(np.linalg.norm(model))
                else:
                    intensity = 50.0
                    warnings.append(
                        f"magnetometer in {bias_unit!r}, no magnetic model for the field's intensity: the hard-iron "
                        "prior --mag-bias-sigma is scaled assuming 50 uT"
                    )
                s_bias *= float(median(np.linalg.norm(m_b, axis=1))) / intensity
            quiet = quiet_mask(f_b, g, fs)
            # f = -g is a sharp reference where the sensor is quiet, a loose one (SIGMA_LOW_DYNAMICS) elsewhere
            extra = np.where(low_dyn & ~quiet, SIGMA_LOW_DYNAMICS, 0.0)
            # the hard iron the data can show: a bias b spreads the field's norm by up to +-|b| as the sensor turns
            norms = np.linalg.norm(m_b, axis=1)
            spread = 0.5 * float(np.percentile(norms, 97.5) - np.percentile(norms, 2.5))

            def solve(s_mag_bias: float):
                return gyro_dmc_attitude(
                    t[rows],
                    f_b,
                    m_b,
                    w_b,
                    f_ref,
                    m_ref,
                    g,
                    dmc=res,
                    sigma_acc=sigma_acc,
                    sigma_mag=sigma_mag,
                    gyro_noise=gyro_noise,
                    bias_walk=bias_walk,
                    sigma_mag_bias=s_mag_bias,
                    # without a GNSS acceleration the specific force's only references are low-dynamics ones: its
                    # bias is not observable there and would trade against the hard iron
                    sigma_acc_bias=sigma_acc_bias if (~low_dyn).any() else 0.0,
                    lat_deg=site[0] if site is not None else None,
                    coriolis=cor,
                    acc_sigma_rows=extra,
                )

            gyro_res, why = None, ""
            try:
                gyro_res = solve(s_bias)
                if gyro_res.bias_mag is not None:
                    # what the data can show: a real hard iron b makes |m - b| steadier than |m| as the sensor
                    # turns; an estimate that makes it less steady, or as large as the field itself, is not one
                    size = float(np.linalg.norm(gyro_res.bias_mag))
                    field = float(median(norms))
                    fixed = np.linalg.norm(m_b - gyro_res.bias_mag, axis=1)
                    spread_b = 0.5 * float(np.percentile(fixed, 97.5) - np.percentile(fixed, 2.5))
                    if size > 0.5 * field or spread_b > spread + sigma_mag * field:
                        warnings.append(
                            f"the magnetometer hard-iron estimate ({size:.3g} {bias_unit}) is more than the data show "
                            f"(field norm {field:.3g}, its spread +-{spread:.2g}, +-{spread_b:.2g} with the estimate "
                            "removed): not estimated"
                        )
                        gyro_res = solve(0.0)
                why = _gyro_check(gyro_res, res, f_b, m_b, m_ref, g, fs, ~low_dyn | quiet, info)
            except (ValueError, np.linalg.LinAlgError) as exc:
                why = f"it failed ({exc})"
            if why:
                warnings.append(f"the gyro-stabilised attitude is not used ({why}): attitude from the DMC alone")
            else:
                res = gyro_res  # type: ignore[assignment]
                method = "gyro+dmc"
                info["iterations"] = res.iterations
                if res.bias_mag is not None:
                    info["bias_mag"] = [float(v) for v in res.bias_mag]
                    info["bias_mag_unit"] = bias_unit
                if res.bias_acc is not None:
                    info["bias_acc"] = [float(v) for v in res.bias_acc]
    info["method"] = method
    a_dmc = ned_to_local(res.acc_kin_ned, azimuth_deg)
    # plausibility against the model where there is one (else the reference used), see magnetometer_plausibility
    check_ref = m_ref if mag_ref is not None or model is None else model
    norm_ref = float(np.linalg.norm(model)) if model is not None and mag_unit == "uT" else None
    flag, ang_err, ratio = magnetometer_plausibility(
        f_b,
        m_b,
        f_ref,
        check_ref,
        norm_ref,
        angle_tol_deg=angle_tol,
        norm_tol=norm_tol,
        window=int(round(fs)),
        reference_ok=quiet_mask(f_b, g, fs),  # the angle only where f = -g is known (a GNSS acceleration in a
        # float episode is off by degrees and would blame the magnetometer)
    )
    med_ratio = float(np.nanmedian(ratio))
    med_err = float(np.nanmedian(ang_err)) if np.isfinite(ang_err).any() else float("nan")
    info.update({"mag_implausible": int(flag.sum()), "mag_norm_ratio": med_ratio, "mag_angle_error_deg": med_err})
    if flag.any():
        what = f"model {norm_ref:.1f} uT" if norm_ref is not None else "its median"
        angle = (
            f"field-to-gravity angle off the model's by {med_err:+.1f} deg median (limit {angle_tol:g} deg)"
            if np.isfinite(med_err)
            else "field-to-gravity angle not checked (no quiet sample, where f = -g is known)"
        )
        warnings.append(
            f"magnetometer implausible on {int(flag.sum())} of {flag.size} row(s) (flagged in mag_implausible): "
            f"field norm median {med_ratio * (norm_ref or 1.0):.1f}{' uT' if norm_ref else ''} vs {what} "
            f"(limit {norm_tol:.0%}), {angle}"
        )
    cols: dict[str, np.ndarray] = {}

    def put(name: str, v: np.ndarray) -> None:
        out = np.full(n, np.nan)
        out[rows] = v
        cols[name] = out

    for i in range(4):
        put(f"q{i}", res.q[:, i])
    put("roll", res.roll)
    put("pitch", res.pitch)
    put("yaw", res.yaw)
    put("quest_loss", res.loss)
    mask = np.zeros(n, bool)
    mask[rows] = True
    sing = np.zeros(n, bool)
    sing[rows] = res.singular
    cols["dmc_singular"] = schema.numeric_array(sing, ~mask)  # null on rows without an attitude
    for i, a in enumerate("xyz"):
        put(f"a{a}_dmc", a_dmc[:, i])
    if res.bias_gyr is not None and res.std_rpy is not None:
        for i, a in enumerate("xyz"):
            put(f"bias_gyr_{a}", res.bias_gyr[:, i])
        for i, name in enumerate(("roll", "pitch", "yaw")):
            put(f"std_{name}", res.std_rpy[:, i])
    if res.bias_mag is not None and res.std_bias_mag is not None:
        for i, a in enumerate("xyz"):
            put(f"bias_mag_{a}", np.full(rows.size, res.bias_mag[i]))
            put(f"std_bias_mag_{a}", np.full(rows.size, res.std_bias_mag[i]))
    if res.bias_acc is not None and res.std_bias_acc is not None:
        for i, a in enumerate("xyz"):
            put(f"bias_acc_{a}", np.full(rows.size, res.bias_acc[i]))
            put(f"std_bias_acc_{a}", np.full(rows.size, res.std_bias_acc[i]))
    bad = np.zeros(n, bool)
    bad[rows] = flag
    cols["mag_implausible"] = schema.numeric_array(bad, ~mask)
    info.update({"rows": int(rows.size), "singular": int(res.singular.sum()), "rate_hz": fs})
    return DMCSessionResult(cols, mask, info, warnings)


def _gyro_check(gyro, dmc, f_b, m_b, m_ref, g: float, fs: float, trusted: np.ndarray, info: dict) -> str:
    """Why the gyro-stabilised solution is not to be used ("" when it passes).

    It must have converged and be consistent with what the samples show beyond doubt:

    * where the DMC's own reference is sound (a GNSS acceleration, or a quiet sample under f = -g; at
      least 1 s of them), its median angle to the per-sample DMC is at most ``MAX_DMC_DISAGREEMENT``;
    * the measured field (its hard iron removed) lies within ``MAX_FIELD_RESIDUAL`` of the reference
      field rotated into the body, in the median;
    * over windows of 20 s, where the athlete's own accelerations average out, the mean specific force
      rotated into NED points up within ``MAX_TILT_RESIDUAL``, in the median.
    """
    from sportfusion.core.rotations import dcm_from_quat

    if not gyro.converged:
        return f"it did not converge in {gyro.iterations} iterations"
    ok = np.all(np.isfinite(gyro.q), axis=1)
    M = dcm_from_quat(np.where(ok[:, None], gyro.q, [1.0, 0.0, 0.0, 0.0]))  # NED -> body
    trusted = trusted & ~dmc.singular & ok
    if trusted.sum() >= max(fs, 2):
        apart = _median_angle_deg(gyro.q[trusted], dmc.q[trusted], np.zeros(int(trusted.sum()), bool))
        info["gyro_dmc_disagreement_deg"] = apart
        if apart > MAX_DMC_DISAGREEMENT:
            return (
                f"it is {apart:.0f} deg from the per-sample DMC where that is sound, in the median "
                f"(limit {MAX_DMC_DISAGREEMENT:g})"
            )
    m = m_b - (gyro.bias_mag if gyro.bias_mag is not None else 0.0)
    mu = m / np.linalg.norm(m, axis=1, keepdims=True)
    pred = np.einsum("nij,j->ni", M, m_ref / np.linalg.norm(m_ref))
    resid = float(np.degrees(np.arccos(np.clip(median(np.einsum("ij,ij->i", mu[ok], pred[ok])), -1, 1))))
    info["gyro_field_residual_deg"] = resid
    if resid > MAX_FIELD_RESIDUAL:
        return f"the measured field is {resid:.0f} deg from the reference in its attitude, in the median"
    f_ned = np.einsum("nji,nj->ni", M, f_b)  # body -> NED (M^T f)
    win = max(int(round(20.0 * fs)), 1)
    k = (f_ned.shape[0] // win) * win
    if k >= win:
        mean = f_ned[:k].reshape(-1, win, 3).mean(axis=1)
        up = -mean[:, 2] / np.linalg.norm(mean, axis=1)
        tilt = float(np.degrees(np.arccos(np.clip(median(up), -1, 1))))
        info["gyro_tilt_residual_deg"] = tilt
        if tilt > MAX_TILT_RESIDUAL:
            return f"its mean specific force over 20 s points {tilt:.0f} deg from up, in the median"
    return ""


def _median_angle_deg(qa: np.ndarray, qb: np.ndarray, skip: np.ndarray) -> float:
    """Median rotation angle [deg] between two attitude histories (scalar-first quaternions), rows not ``skip``."""
    ok = ~np.asarray(skip, bool) & np.all(np.isfinite(qa), axis=1) & np.all(np.isfinite(qb), axis=1)
    if not ok.any():
        return 0.0
    dot = np.abs(np.einsum("ij,ij->i", qa[ok], qb[ok]))
    return float(np.degrees(2.0 * np.arccos(np.clip(median(dot), -1.0, 1.0))))


def gyro_sampling(meta: dict) -> tuple[str, str]:
    """What the session's gyro samples are, from its metadata: ``("mean" | "instant", why)``.

    ``simulate skirace`` writes interval means (a delta-angle gyro), also into the raw files it exports
    (their device brand is ``sportfusion``); a recording read by ``ingest`` from any other device (phones,
    MEMS loggers) samples the rate at the instant; without either clue, interval means.
    """
    tools = [str(p.get("tool", "")) for p in meta.get("provenance") or []]
    sources = meta.get("sources") or []
    simulated = any(t.startswith("simulate") for t in tools) or any(
        str((s.get("device") or {}).get("deviceBrand", "")).lower() == "sportfusion" for s in sources
    )
    if simulated:
        return "mean", "a simulated gyro: each sample the mean rate over its interval"
    if sources or "ingest" in tools:
        return "instant", "a recorded gyro (phone, MEMS logger): each sample the rate at its instant"
    return "mean", "no recording source in the metadata: each sample taken as the mean rate over its interval"


def _xyz(table: pa.Table, prefix: str, suffix: str = "") -> np.ndarray | None:
    from sportfusion.core.schema import float_columns

    names = [f"{prefix}{a}{suffix}" for a in "xyz"]
    if not all(n in table.column_names for n in names):
        return None
    return float_columns(table, names)


def session_site(table: pa.Table, meta: dict) -> tuple[float, float, float] | None:
    """The session's site: median of the ``lat lon h`` columns, else the metadata frame origin, else None."""
    from sportfusion.core.schema import floats

    if "lat" in table.column_names and "lon" in table.column_names:
        lat, lon = floats(table, "lat"), floats(table, "lon")
        ok = np.isfinite(lat) & np.isfinite(lon)
        if ok.any():
            h = floats(table, "h") if "h" in table.column_names else np.zeros_like(lat)
            hh = h[ok & np.isfinite(h)]
            return float(median(lat[ok])), float(median(lon[ok])), float(median(hh)) if hh.size else 0.0
    origin = (meta.get("frame") or {}).get("origin")
    if origin:
        return float(origin[0]), float(origin[1]), float(origin[2])
    return None


def dmc_table(
    table: pa.Table,
    meta: dict,
    *,
    site: tuple[float, float, float] | None = None,
    date: str | None = None,
    **options: object,
) -> DMCSessionResult:
    """:func:`dmc_session` on a session table: reads the columns, site, date and frame, returns the columns to add.

    ``site`` and ``date`` override the session's (lat/lon/h columns or frame
    origin; ``time.epoch_utc`` plus the middle of the session).  Other
    ``options`` are those of :func:`dmc_session`.
    """
    from sportfusion.core.meta import epoch_unix
    from sportfusion.core.schema import floats, require_columns

    require_columns(table, ("acc_x", "acc_y", "acc_z", "mag_x", "mag_y", "mag_z"), "dmc-attitude")
    t = floats(table, "t")
    when: float | str | None = date
    if when is None:
        epoch = epoch_unix(meta)
        if epoch is not None:
            when = epoch + float(median(t))
    hill = meta.get("hill") or {}
    g0 = options.pop("g0", None) or hill.get("g0")
    unit = (meta.get("units") or {}).get("mag_x")
    fmeta = table.schema.field("mag_x").metadata or {}
    unit = unit or (fmeta.get(b"unit", b"uT").decode() if isinstance(fmeta, dict) else "uT")
    return dmc_session(
        t,
        _xyz(table, "acc_"),  # type: ignore[arg-type]
        _xyz(table, "mag_"),  # type: ignore[arg-type]
        acc_kin=_xyz(table, "a"),
        vel=_xyz(table, "v"),
        gyr=_xyz(table, "gyr_"),
        azimuth_deg=float((meta.get("frame") or {}).get("azimuth_deg", 0.0)),
        site=site or session_site(table, meta),
        when=when,
        g0=g0,  # type: ignore[arg-type]
        mag_unit=unit,
        **options,  # type: ignore[arg-type]
    )
