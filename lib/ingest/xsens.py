"""Xsens MT Manager text exports (MTw Awinda, MTi; MT Manager 4.x to 2022): one file per sensor.

Layout: ``//`` header lines, then one line of column names and the samples.
Old exports have a short header (``Start Time``, ``Update Rate: 100.0Hz``,
``Filter Profile``, ``Option Flags``, ``Firmware Version``); MT Manager
2019+ writes a long one (``// General information:``, ``//  MT Manager
version: 2022.2.0``, ``// Device information:``, ``//  DeviceId``, ...,
``// Coordinate system: ENU``) that often has no update rate.  Delimiter tab,
comma, semicolon or space (detected; a trailing delimiter on every line is
dropped); ``NaN`` and empty cells are nulls.

Columns (units)
    ``Acc_X/Y/Z`` -> ``acc_x/y/z`` [m/s^2]; ``Gyr_X/Y/Z`` -> ``gyr_x/y/z``
    [rad/s]; ``Mag_X/Y/Z`` -> ``mag_x/y/z``, normalised to the local field at
    calibration (unit ``1``, declared in the metadata's ``units``);
    ``Pressure`` -> ``pressure`` [Pa].  Orientation as ``Quat_q0..q3`` (q0
    scalar), ``Mat[i][j]`` (matched by its indices) or Euler angles
    ``Roll/Pitch/Yaw`` (or ``Euler_X/Y/Z``) [deg]: Xsens' q_GS / R_GS rotates
    sensor-frame vectors into the global frame G that the header's
    ``Coordinate system`` names (ENU, the default, NWU or NED; Euler angles
    are z-y-x in G).  It is converted to the suite's convention (docs/frames.md,
    :mod:`sportfusion.core.rotations`): ``q_BO`` maps NED into the sensor
    (body) frame, scalar first, so ``M_BO = (C_NG R_GS)^T``.  Exports with
    IMU columns keep it as the device's own orientation ``dev_q0..3``;
    orientation-only exports give the attitude ``q0..q3``.  Other columns
    (``FreeAcc_*``, status words, ...) are listed in the metadata and not read.

Invalid markers
    MT Manager writes an empty cell (or ``NaN``) where a packet lacks a
    value: null.  An orientation that is no rotation (a quaternion of zeros,
    or a matrix off orthonormal by more than :data:`ROTATION_TOL`) is read as
    null, counted in one warning, never converted into an attitude.

Frame check
    With ``Acc_*`` and/or ``Mag_*`` beside the orientation, the stated frame
    is verified: the specific force rotated into NED must point up and the
    horizontal magnetic field north (within 45 degrees: declination plus
    disturbance).  When the stated (or default) frame fails and another of
    ENU/NWU/NED passes, that one is used and a warning gives both headings.

Time
    From ``SampleTimeFine`` (ticks of 100 us, 32-bit, unwrapped) when every
    row has it, else ``PacketCounter`` (16-bit, unwrapped) divided by the
    header's update (or sampling) rate or by ``--rate`` (which wins, with a
    warning when they differ); without either counter, rows are consecutive
    samples at ``--rate`` (warning).  ``t`` counts from the first sample.  The
    recording has an absolute time when the export carries ``UTC_Year ..
    UTC_Second`` (+ ``UTC_Nano``) with ``UTC_Valid`` bits 0 and 1 (date, time
    of day valid) set on some row: the epoch is that row's UTC minus its
    ``t``.  Otherwise there is no absolute time (warning; use ``--offset``).
"""

from __future__ import annotations

import calendar
import re
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.rotations import dcm_from_euler, dcm_from_quat, quat_from_dcm
from sportfusion.core.session import Stream
from sportfusion.core.stats import median
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, floats, read_delimited

TICK = 1e-4  # s per SampleTimeFine tick
_RATE = re.compile(r"([0-9.]+)\s*Hz", re.I)
_MAT = re.compile(r"^Mat\[(\d)\]\[(\d)\]$")
_AXES = {"Acc": "acc", "Gyr": "gyr", "Mag": "mag"}
_COLUMN_LINE = re.compile(r"\b(PacketCounter|SampleTimeFine|Acc_X|Gyr_X|Mag_X|Quat_q0|Euler_X)\b|Mat\[1\]\[1\]")
#: Global frame G -> NED, per the header's "Coordinate system".
FRAMES: dict[str, np.ndarray] = {
    "ENU": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
    "NWU": np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
    "NED": np.eye(3),
}
#: Largest |heading| of the horizontal field in NED for a frame to pass [deg].
HEADING_TOL_DEG = 45.0


def sniff(path: Path, head: bytes) -> bool:
    """``//`` header lines followed by a column line naming Xsens columns, or such a column line first."""
    text = decode(head)
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines or not lines[0].lstrip().startswith("//"):
        # exports without the // block still start with the Xsens column names
        return bool(lines) and bool(re.match(r"^(PacketCounter|SampleTimeFine)\b", lines[0].strip()))
    for ln in lines:
        if not ln.lstrip().startswith("//"):
            return bool(_COLUMN_LINE.search(ln)) or ("Roll" in ln and "Yaw" in ln)
    return any(k in text for k in ("Update Rate", "MT Manager", "Coordinate system", "Xsens"))


def _unwrap(v: np.ndarray, bits: int) -> np.ndarray:
    step = np.diff(v)
    wraps = np.concatenate([[0], np.cumsum(step < -(2 ** (bits - 1)))])
    return v + wraps * float(2**bits)


#: Wrap period [s] of each counter, from the times it gave (PacketCounter: 2^16 samples at the rate).
_WRAP_S = {
    "SampleTimeFine": lambda t: float(2**32) * TICK,
    "PacketCounter": lambda t: float(2**16) * float(median(np.diff(t))) if t.size > 1 else None,
}


def _timing(table: Any, names: list[str], header: dict[str, str], opts: Options, path: Path, warnings: list[str]):
    """Sample times [s] from the first sample, the rows kept, and where the times came from."""
    rate = None
    for key, val in header.items():  # "Update Rate: 100.0Hz", "Sampling Rate", "Sample rate", ...
        m = _RATE.search(val) if "rate" in key.lower() else None
        if m:
            rate = float(m.group(1))
            break
    given = getattr(opts, "rate", None)
    if given and rate and abs(given - rate) > 1e-9 * rate:
        warnings.append(f"--rate {given:g} Hz overrides the header's {rate:g} Hz")
    rate = given or rate
    n = table.num_rows
    keep = np.ones(n, dtype=bool)
    stf = floats(table, "SampleTimeFine") if "SampleTimeFine" in names else None
    pc = floats(table, "PacketCounter") if "PacketCounter" in names else None
    if stf is not None and np.isfinite(stf).all():
        return _unwrap(stf, 32) * TICK, keep, "SampleTimeFine"
    if pc is not None and rate and np.isfinite(pc).any():
        keep = np.isfinite(pc)
        if not keep.all():
            warnings.append(f"{int((~keep).sum())} row(s) without PacketCounter dropped")
        return _unwrap(pc[keep], 16) / rate, keep, "PacketCounter"
    if stf is not None and np.isfinite(stf).any() and not rate:
        keep = np.isfinite(stf)
        warnings.append(f"{int((~keep).sum())} row(s) without SampleTimeFine dropped")
        return _unwrap(stf[keep], 32) * TICK, keep, "SampleTimeFine"
    if rate and pc is None and stf is None:
        warnings.append(f"no PacketCounter or SampleTimeFine: rows taken as consecutive samples at {rate:g} Hz")
        return np.arange(n) / rate, keep, "row number"
    have = [c for c, v in (("SampleTimeFine", stf), ("PacketCounter", pc)) if v is not None]
    detail = f"{' and '.join(have)} with empty cells" if have else "neither SampleTimeFine nor PacketCounter"
    raise InputError(
        f"{path}: {detail}{'' if rate else ', no Update Rate header'}; expected SampleTimeFine on every row, "
        "or PacketCounter and an 'Update Rate: ...Hz' header (or --rate HZ), to time the samples"
    )


def _r_gs(table: Any, names: list[str]) -> tuple[np.ndarray | None, list[str]]:
    """R_GS (sensor -> global G) per row from quaternion, matrix or Euler columns, and the columns used."""
    quat = [f"Quat_q{i}" for i in range(4)]
    mats = {(int(mm.group(1)), int(mm.group(2))): c for c in names if (mm := _MAT.match(c))}
    euler = next(
        (e for e in (("Roll", "Pitch", "Yaw"), ("Euler_X", "Euler_Y", "Euler_Z")) if all(c in names for c in e)), None
    )
    if all(q in names for q in quat):
        q = np.column_stack([floats(table, c) for c in quat])
        with np.errstate(invalid="ignore"):
            norm = np.linalg.norm(q, axis=1)
        q[~(np.abs(norm - 1.0) <= ROTATION_TOL)] = np.nan  # a zero quaternion is no rotation: null, not normalised
        return np.swapaxes(dcm_from_quat(q), -1, -2), quat  # dcm_from_quat gives the transpose of R(q)
    if len(mats) == 9:
        r = np.empty((table.num_rows, 3, 3))
        for (i, j), c in mats.items():
            r[:, i - 1, j - 1] = floats(table, c)
        return r, list(mats.values())
    if euler is not None:
        a = [np.radians(floats(table, c)) for c in euler]
        return np.swapaxes(dcm_from_euler(*a), -1, -2), list(euler)
    return None, []


#: Largest deviation of |q| (or of the matrix from orthonormal) for an orientation to be a rotation.
ROTATION_TOL = 0.01


def _is_rotation(r: np.ndarray) -> np.ndarray:
    """True per row where R (n, 3, 3) is a rotation within :data:`ROTATION_TOL` (NaN rows: False)."""
    with np.errstate(invalid="ignore"):
        err = np.abs(np.einsum("nji,njk->nik", r, r) - np.eye(3)).max(axis=(1, 2))
    return np.isfinite(err) & (err <= 2 * ROTATION_TOL)


def _headings(r_gs: np.ndarray, acc: np.ndarray | None, mag: np.ndarray | None) -> dict[str, tuple[bool, float]]:
    """Per candidate frame: (passes, median heading of the field in NED [deg])."""
    out: dict[str, tuple[bool, float]] = {}
    for name, c in FRAMES.items():
        r_ns = np.einsum("ij,njk->nik", c, r_gs)
        ok, heading = True, float("nan")
        if acc is not None:
            f = np.einsum("nij,nj->ni", r_ns, acc)
            good = np.isfinite(f).all(axis=1)
            if good.any():
                ok &= bool(median(f[good, 2]) < -0.5 * median(np.linalg.norm(f[good], axis=1)))
        if mag is not None:
            m = np.einsum("nij,nj->ni", r_ns, mag)
            good = np.isfinite(m).all(axis=1) & (np.hypot(m[:, 0], m[:, 1]) > 0)
            if good.any():
                h = np.degrees(np.arctan2(m[good, 1], m[good, 0]))
                heading = float(
                    np.degrees(np.angle(median(np.cos(np.radians(h))) + 1j * median(np.sin(np.radians(h)))))
                )
                ok &= abs(heading) <= HEADING_TOL_DEG
        out[name] = (ok, heading)
    return out


def read(path: Path, opts: Options) -> Recording:
    """Read one sensor's MT Manager text export into one stream (see the module docstring)."""
    try:
        text = decode(path.read_bytes())
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    lines = text.splitlines()
    header: dict[str, str] = {}
    n = 0
    while n < len(lines) and (lines[n].lstrip().startswith("//") or not lines[n].strip()):
        key, _, val = lines[n].lstrip()[2:].partition(":")
        if val.strip():
            header[key.strip()] = val.strip()
        n += 1
    dropped: list[str] = []
    table = read_delimited("\n".join(lines[n:]), str(path), dropped=dropped)
    names = [c.strip() for c in table.column_names]
    table = table.rename_columns(names)
    if table.num_rows == 0:
        raise InputError(f"{path}: the Xsens export has no samples")
    warnings: list[str] = []
    if dropped:
        warnings.append(f"column(s) {', '.join(dropped)} hold text, not numbers: not read")
    t, keep, tname = _timing(table, names, header, opts, path, warnings)
    if not keep.all():
        table = table.filter(pa.array(keep))
    # the first sample's time on the counter's own scale (and the counter's wrap period) [s]: exports of one
    # recording share the counter, so several sensors are synchronised by it (sportfusion.ingest.xsensdir)
    counter = {
        "start_s": float(t[0]),
        "wrap_s": _WRAP_S.get(tname, lambda r: None)(t),
        "step_s": TICK if tname == "SampleTimeFine" else (float(median(np.diff(t))) if t.size > 1 else None),
    }
    t = t - t[0]
    cols: dict[str, object] = {}
    used = {"SampleTimeFine", "PacketCounter"}
    for prefix, col in _AXES.items():
        for a in "XYZ":
            name = f"{prefix}_{a}"
            if name in names:
                cols[f"{col}_{a.lower()}"] = floats(table, name)
                used.add(name)
    if "Pressure" in names:
        cols["pressure"] = floats(table, "Pressure")
        used.add("Pressure")
    imu = any(k.startswith(("acc_", "gyr_", "mag_")) for k in cols)
    r_gs, ori_cols = _r_gs(table, names)
    used.update(ori_cols)
    meta: dict[str, Any] = {"header": header, "time_from": tname, "counter": counter}
    if r_gs is not None:
        rot = _is_rotation(r_gs)
        written = np.isfinite(np.column_stack([floats(table, c) for c in ori_cols])).all(axis=1)
        r_gs[~rot] = np.nan  # no rotation: kept out of the frame check and of the attitude
        stated = header.get("Coordinate system", "").strip().upper()
        frame = stated if stated in FRAMES else "ENU"
        if stated and stated not in FRAMES:
            warnings.append(f"'Coordinate system: {stated}' is not ENU, NWU or NED; ENU assumed")
        acc = np.column_stack([cols[f"acc_{a}"] for a in "xyz"]) if "acc_x" in cols and "acc_z" in cols else None
        mag = np.column_stack([cols[f"mag_{a}"] for a in "xyz"]) if "mag_x" in cols and "mag_z" in cols else None
        if acc is not None or mag is not None:
            fits = _headings(r_gs, acc, mag)
            passing = [f for f, (ok, _) in fits.items() if ok]
            if not fits[frame][0] and passing:
                said = f"stated {frame}" if stated else f"{frame} (no Coordinate system line)"
                warnings.append(
                    f"orientation frame {said} puts magnetic north at {fits[frame][1]:.0f} deg and/or gravity off the "
                    f"vertical; {passing[0]} fits the Acc/Mag columns (north at {fits[passing[0]][1]:.0f} deg): "
                    f"converted as {passing[0]}"
                )
                frame = passing[0]
            elif not fits[frame][0]:
                warnings.append(
                    f"orientation frame {frame}: the Acc/Mag columns fit no frame (north at {fits[frame][1]:.0f} deg); "
                    "converted as stated"
                )
            meta["frame_check"] = {f: {"passes": ok, "north_deg": h} for f, (ok, h) in fits.items()}
        elif not stated:
            warnings.append(
                "no 'Coordinate system' line and no Acc/Mag to check: orientation taken in ENU (MT Manager's default)"
            )
        m_bo = np.swapaxes(np.einsum("ij,njk->nik", FRAMES[frame], r_gs), -1, -2)
        good = np.isfinite(m_bo).all(axis=(1, 2))
        if (written & ~rot).any():
            warnings.append(
                f"invalid markers read as null: {int((written & ~rot).sum())} orientation(s) that are no rotation "
                f"(a zero quaternion or matrix, as written before the filter has a solution) in {', '.join(ori_cols[:1])}..."
            )
        q = np.full((table.num_rows, 4), np.nan)
        if good.any():
            q[good] = quat_from_dcm(m_bo[good])
        prefix = "dev_q" if imu else "q"
        for i in range(4):
            cols[f"{prefix}{i}"] = q[:, i]
        meta["orientation"] = (
            f"{prefix}0..3 = q_BO (NED -> sensor, scalar first), from the export's {frame} orientation "
            f"({', '.join(ori_cols[:1])}...)"
        )
        meta["frame"] = frame
    if not cols:
        raise InputError(
            f"{path}: no Acc_X/Gyr_X/Mag_X or orientation (Quat_q0, Mat[1][1], Roll/Pitch/Yaw) column "
            f"(columns: {', '.join(names)})"
        )
    epoch = _utc_epoch(table, names, t)
    if epoch is None:
        warnings.append("no valid UTC columns: the export has no absolute time; align it by --offset NAME=SECONDS")
    utc_cols = {c for c in names if c.startswith("UTC_")}
    meta["ignored_columns"] = [c for c in names if c not in used and c not in utc_cols]
    if "mag_x" in cols:
        meta["units"] = {f"mag_{a}": "1" for a in "xyz"}
    return Recording(str(path), "xsens", [Stream(path.stem, t, cols)], epoch, meta, warnings)


def _utc_epoch(table: Any, names: list[str], t: np.ndarray) -> float | None:
    need = ["UTC_Year", "UTC_Month", "UTC_Day", "UTC_Hour", "UTC_Minute", "UTC_Second"]
    if not all(c in names for c in need):
        return None
    vals = [floats(table, c) for c in need]
    nano = floats(table, "UTC_Nano") if "UTC_Nano" in names else np.zeros(table.num_rows)
    valid = np.isfinite(np.column_stack(vals)).all(axis=1) & (vals[0] > 1970)
    if "UTC_Valid" in names:
        flag = floats(table, "UTC_Valid")
        valid &= np.isfinite(flag) & (
            (np.nan_to_num(flag).astype(np.int64) & 0x03) == 0x03
        )  # bits 0, 1: date and time valid
    if not valid.any():
        return None
    i = int(np.argmax(valid))
    y, mo, d, h, mi, s = (int(v[i]) for v in vals)
    whole = calendar.timegm((y, mo, d, h, mi, s, 0, 0, 0))
    frac = float(nano[i]) * 1e-9 if np.isfinite(nano[i]) else 0.0
    return whole + frac - float(t[i])
