"""Xsens MT Manager text exports (MTw Awinda, MTi): one file per sensor.

Layout: ``//`` header lines (``Start Time``, ``Update Rate: 100.0Hz``,
``Filter Profile``, ``Option Flags``, ``Firmware Version``, ...), then one
line of column names and the samples, tab-separated (semicolon or comma
exports are detected as well; a trailing separator on every line is
dropped).

Columns (units)
    ``Acc_X/Y/Z`` -> ``acc_x/y/z`` [m/s^2]; ``Gyr_X/Y/Z`` -> ``gyr_x/y/z``
    [rad/s]; ``Mag_X/Y/Z`` -> ``mag_x/y/z``, normalised to the local field at
    calibration (unit ``1``, declared in the metadata's ``units``);
    ``Pressure`` -> ``pressure`` [Pa]; the orientation ``Quat_q0..q3`` (q0
    scalar) or ``Mat[i][j]`` (matched by its indices, converted to a
    quaternion) -> ``dev_q0..3``: Xsens' q_GS, rotating sensor-frame vectors
    into the global frame (ENU unless the device was set to NED).  Other
    columns (``FreeAcc_*``, Euler angles, status words, ...) are listed in the
    metadata and not read.

Time
    From ``SampleTimeFine`` (ticks of 100 us, 32-bit, unwrapped) when every
    row has it, else ``PacketCounter`` (16-bit, unwrapped; some exports leave
    SampleTimeFine empty) divided by the header's update (or sampling) rate.  ``t`` counts from the first sample.  The recording has an absolute
    time when the export carries ``UTC_Year .. UTC_Second`` (+ ``UTC_Nano``)
    with ``UTC_Valid`` bits 0 and 1 (date, time of day valid) set on some row: the epoch is that row's UTC minus its
    ``t``.  Otherwise there is no absolute time (warning; use ``--offset``).
"""

from __future__ import annotations

import calendar
import re
from pathlib import Path
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.rotations import quat_from_dcm
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, floats, read_delimited

TICK = 1e-4  # s per SampleTimeFine tick
_RATE = re.compile(r"([0-9.]+)\s*Hz", re.I)
_MAT = re.compile(r"^Mat\[(\d)\]\[(\d)\]$")
_AXES = {"Acc": "acc", "Gyr": "gyr", "Mag": "mag"}


def sniff(path: Path, head: bytes) -> bool:
    """``//`` header lines followed by a column line naming Acc_/Gyr_/PacketCounter/SampleTimeFine."""
    text = decode(head)
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines or not lines[0].lstrip().startswith("//"):
        # exports without the // block still start with the Xsens column names
        return bool(lines) and bool(re.match(r"^(PacketCounter|SampleTimeFine)\b", lines[0].strip()))
    for ln in lines:
        if not ln.lstrip().startswith("//"):
            return bool(re.search(r"\b(PacketCounter|SampleTimeFine|Acc_X|Gyr_X)\b", ln))
    return "Update Rate" in text


def _unwrap(v: np.ndarray, bits: int) -> np.ndarray:
    step = np.diff(v)
    wraps = np.concatenate([[0], np.cumsum(step < -(2 ** (bits - 1)))])
    return v + wraps * float(2**bits)


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
        if val:
            header[key.strip()] = val.strip()
        n += 1
    table = read_delimited("\n".join(lines[n:]), str(path))
    names = [c.strip() for c in table.column_names]
    table = table.rename_columns(names)
    if table.num_rows == 0:
        raise InputError(f"{path}: the Xsens export has no samples")
    warnings: list[str] = []
    rate = None
    m = _RATE.search(header.get("Update Rate", header.get("Sampling Rate", "")))
    if m:
        rate = float(m.group(1))
    stf = floats(table, "SampleTimeFine") if "SampleTimeFine" in names else None
    pc = floats(table, "PacketCounter") if "PacketCounter" in names else None
    if stf is not None and np.isfinite(stf).all():
        tname = "SampleTimeFine"
        t = _unwrap(stf, 32) * TICK
    elif pc is not None and rate and np.isfinite(pc).all():
        tname = "PacketCounter"
        t = _unwrap(pc, 16) / rate
    else:
        have = [c for c, v in (("SampleTimeFine", stf), ("PacketCounter", pc)) if v is not None]
        detail = f"{' and '.join(have)} with empty cells" if have else "neither SampleTimeFine nor PacketCounter"
        raise InputError(
            f"{path}: {detail}{'' if rate else ', no Update Rate header'}; expected SampleTimeFine on every row, "
            "or PacketCounter on every row and an 'Update Rate: ...Hz' header, to time the samples"
        )
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
    quat = [f"Quat_q{i}" for i in range(4)]
    mats = {(int(mm.group(1)), int(mm.group(2))): c for c in names if (mm := _MAT.match(c))}
    if all(q in names for q in quat):
        q = np.column_stack([floats(table, c) for c in quat])
        used.update(quat)
    elif len(mats) == 9:
        r = np.empty((table.num_rows, 3, 3))
        for (i, j), c in mats.items():
            r[:, i - 1, j - 1] = floats(table, c)
        q = quat_from_dcm(np.swapaxes(r, -1, -2))  # quat_from_dcm takes the transpose of R(q)
        used.update(mats.values())
    else:
        q = None
    if q is not None:
        for i in range(4):
            cols[f"dev_q{i}"] = q[:, i]
    if not any(k.startswith(("acc_", "gyr_", "mag_")) for k in cols):
        raise InputError(f"{path}: no Acc_X/Gyr_X/Mag_X column (columns: {', '.join(names)})")
    epoch = _utc_epoch(table, names, t)
    if epoch is None:
        warnings.append("no valid UTC columns: the export has no absolute time; align it by --offset NAME=SECONDS")
    utc_cols = {c for c in names if c.startswith("UTC_")}
    meta: dict[str, Any] = {
        "header": header,
        "time_from": tname,
        "ignored_columns": [c for c in names if c not in used and c not in utc_cols],
    }
    if "mag_x" in cols:
        meta["units"] = {f"mag_{a}": "1" for a in "xyz"}
    if q is not None:
        meta["orientation"] = "dev_q = Xsens q_GS (sensor -> global, ENU unless the device was set to NED)"
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
