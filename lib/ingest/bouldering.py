"""One hand of a trial of the bouldering dataset layout (Koller, Laue, Frese), and its hold map.

Layout (``docs/formats.md``)::

    <dataset>/data_set.json                       magnet_in_art_V01, _V02: field vector, mocap frame
    <dataset>/P01/V01/trials/T1/trial_data.json   TrackID, start_time, end_time, descent_time,
                                                  data_mask {sensor: 0/1}, has_outliers {sensor: 0/1}
    <dataset>/P01/V01/trials/T1/imu_lefthand.csv  1 header line, 14 columns: t [s], acc xyz [m/s^2],
                                                  gyr xyz [rad/s], mag xyz [normalised],
                                                  Xsens orientation quaternion w x y z
    <map>/routes/<TrackID>.csv                    1 header line, rows index,x,y,z: hold centres [m]
    <map>/start_handles.json                      {TrackID: [i, j]}: the two start holds

The input is the trial folder (or its ``imu_<hand>.csv``; the hand is then
taken from the file name, else ``Options.hand``).  Columns are read by
position (the header's names are not standardised): ``t``,
``acc_x/y/z``, ``gyr_x/y/z``, ``mag_x/y/z`` (unit ``1``, declared in the
metadata's ``units``), ``dev_q0..3`` (Xsens q_GS, w first).  ``t`` is kept
as written, so the trial's ``start_time``, ``end_time`` and
``descent_time`` stay on the same clock; the recording has no absolute time.
Samples beyond the sensor range (|acc| > 160 m/s^2 on an axis, |gyr| > 2000
deg/s on an axis, |mag| > 1.9 on an axis) are counted in a warning; they are
kept (``detect-events --kind grips`` flags them).

The session metadata gets ``climbing``: ``route`` (TrackID), ``descent_time``
[s] (both read by ``pf-holds``), ``start_time``, ``end_time``, ``hand``,
``participant``, ``visit``, ``trial``, ``data_mask``, ``has_outliers``.

Hold map
    Found at ``Options.hold_map`` or, failing that, the nearest folder holding
    ``start_handles.json`` and ``routes/`` at or beside the trial's ancestors.
    :func:`read_hold_map` turns it into a ``holds`` table (every route of the
    wall, so the descent can use all holds) with the start holds, the up axis
    (``Options.map_up``, default z) and the visit's reference magnetic field
    (``magnet_in_art_<visit>``, normalised) in its metadata, ready for
    ``pf-holds --holds``.  A hold index that names the same position on every
    route is kept as the hold number; otherwise holds are numbered by position
    (1 mm) and the route's own index is kept in ``route_hold``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.climbing.holds import holds_table
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.core.stats import unique
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, floats, read_delimited

COLUMNS = (
    "t",
    "acc_x",
    "acc_y",
    "acc_z",
    "gyr_x",
    "gyr_y",
    "gyr_z",
    "mag_x",
    "mag_y",
    "mag_z",
    "dev_q0",
    "dev_q1",
    "dev_q2",
    "dev_q3",
)
ACC_LIMIT = 160.0  # m/s^2
GYR_LIMIT = float(np.deg2rad(2000.0))  # rad/s
MAG_LIMIT = 1.9  # normalised
_IMU = re.compile(r"^imu_(\w+)\.csv$", re.I)


def sniff(path: Path, head: bytes) -> bool:
    """A trial folder (``trial_data.json`` + ``imu_*.csv``) or an ``imu_*.csv`` inside one."""
    if path.is_dir():
        return (path / "trial_data.json").is_file() and any(path.glob("imu_*.csv"))
    return bool(_IMU.match(path.name)) and (path.parent / "trial_data.json").is_file()


def _json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not readable JSON ({exc})") from exc


def _find_upwards(start: Path, test: Any, levels: int = 6) -> Path | None:
    for a in [start, *start.parents][:levels]:
        if test(a):
            return a
        for c in sorted(a.iterdir()) if a.is_dir() else []:
            if c.is_dir() and test(c):
                return c
    return None


def _is_map(p: Path) -> bool:
    return (p / "start_handles.json").is_file() and (p / "routes").is_dir()


def read(path: Path, opts: Options) -> Recording:
    """Read one hand's IMU file of a trial (see the module docstring)."""
    hand = opts.hand
    trial = path
    if path.is_file():
        m = _IMU.match(path.name)
        if m:
            hand = m.group(1)
        trial = path.parent
    if not hand:  # no --hand: the trial's only hand, else ask (a trial usually has both)
        hands = sorted(m.group(1) for p in trial.glob("imu_*.csv") if (m := _IMU.match(p.name)))
        if len(hands) != 1:
            raise InputError(
                f"{trial}: {' and '.join(f'imu_{h}.csv' for h in hands) or 'no imu_<hand>.csv'}; "
                "choose the hand with --hand lefthand or --hand righthand"
            )
        hand = hands[0]
    imu = trial / f"imu_{hand}.csv"
    if not imu.is_file():
        have = ", ".join(sorted(p.name for p in trial.glob("imu_*.csv"))) or "none"
        raise InputError(f"{trial}: no imu_{hand}.csv (found {have}); choose the hand with --hand")
    info = _json(trial / "trial_data.json")
    if not isinstance(info, dict):
        raise InputError(f"{trial / 'trial_data.json'}: expected a JSON object with TrackID, start_time, ...")
    table = read_delimited(decode(imu.read_bytes()), str(imu))
    if table.num_columns != len(COLUMNS):
        raise InputError(
            f"{imu}: {table.num_columns} columns; expected 14 (t, acc xyz, gyr xyz, mag xyz, quaternion w x y z)"
        )
    vals = {c: floats(table, h) for c, h in zip(COLUMNS, table.column_names, strict=True)}
    t = vals.pop("t")
    bad = ~np.isfinite(t)
    if bad.any():
        raise InputError(f"{imu}: row {int(np.argmax(bad)) + 2} has no time; expected a time on every row")
    warnings: list[str] = []
    acc = np.column_stack([vals[f"acc_{a}"] for a in "xyz"])
    gyr = np.column_stack([vals[f"gyr_{a}"] for a in "xyz"])
    mag = np.column_stack([vals[f"mag_{a}"] for a in "xyz"])
    with np.errstate(invalid="ignore"):
        over = {
            "acc": int((np.abs(acc) > ACC_LIMIT).any(axis=1).sum()),
            "gyr": int((np.abs(gyr) > GYR_LIMIT).any(axis=1).sum()),
            "mag": int((np.abs(mag) > MAG_LIMIT).any(axis=1).sum()),
        }
    if any(over.values()):
        warnings.append(
            "samples beyond the sensor range (kept): "
            + ", ".join(f"{k} {n}" for k, n in over.items() if n)
            + " (limits 160 m/s^2, 2000 deg/s, 1.9 normalised)"
        )
    mask = info.get("data_mask") or {}
    for key, flag in mask.items() if isinstance(mask, dict) else []:
        if hand.lower() in str(key).lower() and not flag:
            warnings.append(f"trial_data.json data_mask marks {key} as invalid data")
    parts = trial.resolve().parts
    ids = {}
    if len(parts) >= 4 and parts[-2].lower() == "trials":
        ids = {"participant": parts[-4], "visit": parts[-3], "trial": parts[-1]}
    climbing: dict[str, Any] = {"hand": hand, **ids}
    if "TrackID" in info:
        climbing["route"] = str(info["TrackID"])
    for key in ("descent_time", "start_time", "end_time"):
        if isinstance(info.get(key), (int, float)):
            climbing[key] = float(info[key])
    for key in ("data_mask", "has_outliers"):
        if key in info:
            climbing[key] = info[key]
    meta: dict[str, Any] = {"units": {f"mag_{a}": "1" for a in "xyz"}, "session": {"climbing": climbing}}
    rec = Recording(str(path), "bouldering", [Stream(f"imu_{hand}", t, vals)], None, meta, warnings)

    map_dir = Path(opts.hold_map) if opts.hold_map else _find_upwards(trial, _is_map)
    if map_dir is not None:
        root = _find_upwards(trial, lambda p: (p / "data_set.json").is_file())
        field = None
        if root is not None:
            ds = _json(root / "data_set.json")
            key = f"magnet_in_art_{ids.get('visit', '')}"
            if isinstance(ds, dict) and key in ds:
                field = np.asarray(ds[key], dtype=np.float64)
            else:
                warnings.append(f"data_set.json has no {key}: the hold map gets no reference magnetic field")
        holds, hmeta, hw = read_hold_map(map_dir, field, opts.map_up)
        warnings += hw
        rec.tables["holds"] = (holds, hmeta)
        meta["hold_map"] = str(map_dir)
    return rec


def read_hold_map(
    map_dir: str | Path, magnetic_field: np.ndarray | None = None, up: str = "z"
) -> tuple[pa.Table, dict[str, Any], list[str]]:
    """The dataset's hold map (every route) as a ``holds`` table.

    Parameters
    ----------
    map_dir : path
        Folder with ``routes/<TrackID>.csv`` (index, x, y, z [m]) and ``start_handles.json``.
    magnetic_field : array (3,), optional
        Reference field in the map (mocap) frame; normalised to |m| = 1.
    up : str
        The map's up axis (``x y z -x -y -z``).

    Returns
    -------
    table, meta, warnings
    """
    map_dir = Path(map_dir)
    if not _is_map(map_dir):
        raise InputError(f"{map_dir}: not a hold map folder; expected routes/<TrackID>.csv and start_handles.json")
    starts_raw = _json(map_dir / "start_handles.json")
    if not isinstance(starts_raw, dict):
        raise InputError(f"{map_dir / 'start_handles.json'}: expected {{TrackID: [i, j]}}")
    rows: list[tuple[str, int, np.ndarray]] = []
    for f in sorted((map_dir / "routes").glob("*.csv")):
        tab = read_delimited(decode(f.read_bytes()), str(f))
        if tab.num_columns < 4:
            raise InputError(f"{f}: {tab.num_columns} columns; expected index, x, y, z")
        idx, x, y, z = (floats(tab, h) for h in tab.column_names[:4])
        if not (np.isfinite(idx).all() and np.isfinite(np.column_stack([x, y, z])).all()):
            raise InputError(f"{f}: a hold has a missing index or position; expected index, x, y, z [m] on every row")
        rows += [(f.stem, int(i), np.array([a, b, c])) for i, a, b, c in zip(idx, x, y, z, strict=True)]
    if not rows:
        raise InputError(f"{map_dir / 'routes'}: no route CSV; expected <TrackID>.csv files")
    warnings: list[str] = []
    routes = [r for r, _, _ in rows]
    local = np.array([i for _, i, _ in rows], dtype=np.int64)
    pos = np.array([p for _, _, p in rows])
    consistent = all(np.abs(pos[local == i] - pos[local == i][0]).max() <= 1e-3 for i in unique(local))
    if consistent:
        hold = local.copy()
    else:
        keys = [tuple(np.round(p * 1000).astype(np.int64)) for p in pos]
        numbers: dict[tuple[int, ...], int] = {}
        hold = np.array([numbers.setdefault(k, len(numbers)) for k in keys], dtype=np.int64)
        warnings.append(
            "hold indices differ between routes: holds are numbered by position, route_hold keeps the index"
        )
    starts: dict[str, list[int]] = {}
    for r in dict.fromkeys(routes):
        pair = starts_raw.get(r)
        if not isinstance(pair, list) or len(pair) != 2:
            raise InputError(f"{map_dir / 'start_handles.json'}: no two start holds for route {r!r}")
        sel = np.array(routes) == r
        num = []
        for i in pair:
            hit = np.flatnonzero(sel & (local == int(i)))
            if hit.size == 0:
                raise InputError(f"start_handles.json: start hold {i} of route {r!r} is not in routes/{r}.csv")
            num.append(int(hold[hit[0]]))
        starts[r] = num
    if magnetic_field is not None:
        norm = float(np.linalg.norm(magnetic_field))
        magnetic_field = magnetic_field / norm if norm > 0 else magnetic_field
    table, meta = holds_table(
        routes,
        hold,
        pos,
        starts,
        up=up,
        axes=f"motion-capture (ART) frame of the bouldering dataset, {up} up (frame origin lat/lon not known)",
        magnetic_field=magnetic_field,
    )
    table = table.append_column("route_hold", schema.to_arrow("route_hold", local.astype(np.int32)))
    meta["climbing"]["source"] = str(map_dir)
    return table, meta, warnings
