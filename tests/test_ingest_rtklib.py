"""RTKLIB .pos reader: each layout written here in RTKLIB's own number formats."""

from __future__ import annotations

import calendar
import datetime as dt
import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymap3d
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.ingest import FORMATS, Options, rtklib

BIN = Path(sys.executable).parent
GPS0 = dt.datetime(1980, 1, 6)

LLH_HEAD = """\
% program   : RTKPOST ver.2.4.3 b34
% inp file  : rover.obs
% obs start : 2026/01/05 13:00:18.0 GPST (week2400 133218.0s)
% pos mode  : Kinematic
% (lat/lon/height=WGS84/{height},Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)
"""
LLH_COLS = "%  {time:<23}  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio"
VEL_COLS = "    vn(m/s)    ve(m/s)    vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun"


def llh_line(time, lat, lon, h, q, ns, sd, age, ratio, vel=None):
    s = f"{time}  {lat:14.9f} {lon:14.9f} {h:10.4f} {q:3d} {ns:3d}" + "".join(f" {v:8.4f}" for v in sd)
    s += f" {age:6.2f} {ratio:6.1f}"
    if vel is not None:
        s += f" {vel[0]:10.5f} {vel[1]:10.5f} {vel[2]:10.5f} {vel[3]:9.5f}" + "".join(f" {v:8.5f}" for v in vel[4:])
    return s


def col(rec, name):
    v = rec.streams[0].columns[name]
    if hasattr(v, "to_pylist"):
        return v.to_pylist()
    return [None if np.isnan(x) else float(x) for x in v]


# a fixed - float - float - fixed - single sequence, 0.2 s apart, with velocity
Q_SEQ = [1, 2, 2, 1, 5]
SD = [
    (0.0050, 0.0040, 0.0120, 0.0010, -0.0020, 0.0030),
    (0.1500, 0.2000, 0.4000, -0.0500, 0.0600, -0.0700),
    (0.1600, 0.2100, 0.4100, -0.0500, 0.0600, -0.0700),
    (0.0060, 0.0050, 0.0130, 0.0010, -0.0020, 0.0030),
    (1.5000, 1.2000, 3.0000, 0.3000, -0.2000, 0.1000),
]


def llh_file(tmp_path, *, time="GPST", height="ellipsoidal", vel=True, weektow=False, name="run.pos"):
    lines = [LLH_HEAD.format(height=height).rstrip("\n"), LLH_COLS.format(time=time) + (VEL_COLS if vel else "")]
    for i, (q, sd) in enumerate(zip(Q_SEQ, SD, strict=True)):
        if i == 2:
            lines.append("% a comment line between solutions")
        when = dt.datetime(2026, 1, 5, 13, 0, 18) + dt.timedelta(seconds=0.2 * i)
        if weektow:
            week, tow = divmod((when - GPS0).total_seconds(), 604800)
            stamp = f"{int(week):4d} {tow:10.3f}"
        else:
            stamp = when.strftime("%Y/%m/%d %H:%M:%S.") + f"{when.microsecond // 1000:03d}"
        v = (10.0 + i, 5.0, -1.0 + 0.5 * i, 0.01, 0.02, 0.03, 0.0, 0.0, 0.0) if vel else None
        lines.append(llh_line(stamp, 47.4049 + 1e-6 * i, 10.2945, 960.2 + 0.1 * i, q, 14 - i, sd, 1.0, 12.5 - i, v))
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def test_llh_gpst_with_velocity_float_period(tmp_path):
    rec = rtklib.read(llh_file(tmp_path), Options())
    s = rec.streams[0]
    # GPST 13:00:18 is UTC 13:00:00 (18 leap seconds in 2026)
    assert rec.epoch_utc == calendar.timegm((2026, 1, 5, 13, 0, 0))
    assert s.t == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8], abs=1e-9)
    assert col(rec, "rtk_q") == Q_SEQ
    assert col(rec, "gnss_fix") == [4, 5, 5, 4, 1]
    assert col(rec, "gnss_sats") == [14, 13, 12, 11, 10]
    sd = np.array(SD)
    assert col(rec, "gnss_sigma_n") == pytest.approx(sd[:, 0])
    assert col(rec, "gnss_sigma_e") == pytest.approx(sd[:, 1])
    assert col(rec, "gnss_sigma_v") == pytest.approx(sd[:, 2])
    assert col(rec, "gnss_sdne") == pytest.approx(sd[:, 3])
    assert col(rec, "gnss_sdeu") == pytest.approx(sd[:, 4])
    assert col(rec, "gnss_sdun") == pytest.approx(sd[:, 5])
    assert col(rec, "gnss_sigma_h") == pytest.approx(np.sqrt((sd[:, 0] ** 2 + sd[:, 1] ** 2) / 2))
    assert col(rec, "gnss_age") == [1.0] * 5
    assert col(rec, "gnss_ratio") == pytest.approx([12.5, 11.5, 10.5, 9.5, 8.5])
    assert col(rec, "lat") == pytest.approx(47.4049 + 1e-6 * np.arange(5), abs=1e-10)
    assert col(rec, "h") == pytest.approx(960.2 + 0.1 * np.arange(5), abs=1e-6)
    assert "h_msl" not in s.columns
    assert col(rec, "vel_n") == pytest.approx(10.0 + np.arange(5))
    assert col(rec, "vel_e") == pytest.approx([5.0] * 5)
    assert col(rec, "vel_d") == pytest.approx(1.0 - 0.5 * np.arange(5))  # down = -up
    assert col(rec, "std_vel_n") == pytest.approx([0.01] * 5)
    assert col(rec, "std_vel_d") == pytest.approx([0.03] * 5)
    assert rec.warnings == []
    assert rec.meta["time_system"] == "GPST" and rec.meta["gps_utc_leap_s"] == [18]


def test_week_tow_gives_the_same_times(tmp_path):
    a = rtklib.read(llh_file(tmp_path, weektow=True, vel=False), Options())
    assert a.epoch_utc == calendar.timegm((2026, 1, 5, 13, 0, 0))
    assert a.streams[0].t == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8], abs=1e-9)
    assert "vel_n" not in a.streams[0].columns and "std_vel_n" not in a.streams[0].columns


def test_utc_and_jst_times(tmp_path):
    utc = rtklib.read(llh_file(tmp_path, time="UTC", vel=False), Options())
    assert utc.epoch_utc == calendar.timegm((2026, 1, 5, 13, 0, 18))
    jst = rtklib.read(llh_file(tmp_path, time="JST", vel=False, name="j.pos"), Options())
    assert jst.epoch_utc == calendar.timegm((2026, 1, 5, 4, 0, 18))


def test_geodetic_height_goes_to_h_msl(tmp_path):
    rec = rtklib.read(llh_file(tmp_path, height="geodetic"), Options())
    assert col(rec, "h_msl") == pytest.approx(960.2 + 0.1 * np.arange(5), abs=1e-6)
    assert col(rec, "h") == [None] * 5
    assert len(rec.warnings) == 1 and "geodetic" in rec.warnings[0]


@pytest.mark.parametrize(
    ("gpst", "leap"),
    [  # GPS - UTC from IERS Bulletin C (TAI - UTC minus 19 s)
        ((1985, 1, 1), 3),
        ((1999, 6, 1), 13),
        ((2008, 12, 31, 23, 59, 0), 14),
        ((2010, 6, 1), 15),
        ((2016, 6, 1), 17),
        ((2017, 1, 1, 0, 0, 18), 18),
        ((2026, 1, 5), 18),
    ],
)
def test_leap_second_table(gpst, leap):
    g = calendar.timegm((*gpst, *(0,) * (6 - len(gpst)), 0, 0, 0))
    utc, n = rtklib.gpst_to_utc(np.array([g]))
    assert n.tolist() == [leap] and utc.tolist() == [g - leap]


def test_xyz_converted_and_sigmas_rotated(tmp_path):
    lat0, lon0, h0 = -33.86646, 151.20576, 58.3
    rng = np.random.default_rng(1)
    rows, truth = [], []
    head = "%  GPST                      x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio    vx(m/s)    vy(m/s)    vz(m/s)      sdvx     sdvy     sdvz    sdvxy    sdvyz    sdvzx"
    for i in range(4):
        lat, lon, h = lat0 + 1e-4 * i, lon0 - 2e-4 * i, h0 + i
        x, y, z = pymap3d.geodetic2ecef(lat, lon, h)
        # a correlated ENU covariance and an ENU velocity, taken to ECEF with pymap3d's rotation
        a = rng.normal(size=(3, 3)) * 0.5
        q_enu = a @ a.T + np.diag([0.2, 0.3, 0.5])
        cols = np.array([pymap3d.enu2uvw(*e, lat, lon) for e in np.eye(3)]).T  # ECEF <- ENU
        p = cols @ q_enu @ cols.T
        v_enu = np.array([3.0 + i, -4.0, 0.5])
        vx, vy, vz = pymap3d.enu2uvw(*v_enu, lat, lon)
        sd = [np.sqrt(p[0, 0]), np.sqrt(p[1, 1]), np.sqrt(p[2, 2])]
        sdc = [np.sign(c) * np.sqrt(abs(c)) for c in (p[0, 1], p[1, 2], p[2, 0])]
        week, tow = 2400, 133218.0 + i
        rows.append(
            f"{week:4d} {tow:10.3f} {x:14.4f} {y:14.4f} {z:14.4f} {2:3d} {9:3d}"
            + "".join(f" {v:8.4f}" for v in (*sd, *sdc))
            + f" {0.5:6.2f} {2.1:6.1f} {vx:10.5f} {vy:10.5f} {vz:10.5f}"
            + "".join(f" {v:8.5f}" for v in (0.01, 0.02, 0.03, 0.0, 0.0, 0.0))
        )
        truth.append((q_enu, v_enu, rows[-1]))
    p = tmp_path / "xyz.pos"
    p.write_text(
        "% program   : RTKPOST ver.2.4.3 b34\n% (x/y/z-ecef=WGS84,Q=1:fix,...)\n" + head + "\n" + "\n".join(rows) + "\n"
    )
    rec = rtklib.read(p, Options())
    assert rec.epoch_utc == calendar.timegm((2026, 1, 5, 13, 0, 0))
    for i, (q_enu, v_enu, line) in enumerate(truth):
        x, y, z = (float(v) for v in line.split()[2:5])
        lat, lon, h = pymap3d.ecef2geodetic(x, y, z)
        # < 1 mm: 1e-8 deg of latitude is 1.1 mm, so use 5e-9 deg
        assert col(rec, "lat")[i] == pytest.approx(lat, abs=5e-9)
        assert col(rec, "lon")[i] == pytest.approx(lon, abs=5e-9)
        assert col(rec, "h")[i] == pytest.approx(h, abs=1e-3)
        # sigmas: file rounding is 5e-5 m on each sqrt, so 2e-3 on the rotated values
        assert col(rec, "gnss_sigma_e")[i] == pytest.approx(np.sqrt(q_enu[0, 0]), abs=2e-3)
        assert col(rec, "gnss_sigma_n")[i] == pytest.approx(np.sqrt(q_enu[1, 1]), abs=2e-3)
        assert col(rec, "gnss_sigma_v")[i] == pytest.approx(np.sqrt(q_enu[2, 2]), abs=2e-3)
        sne = np.sign(q_enu[1, 0]) * np.sqrt(abs(q_enu[1, 0]))
        assert col(rec, "gnss_sdne")[i] == pytest.approx(sne, abs=5e-3)
        assert col(rec, "vel_e")[i] == pytest.approx(v_enu[0], abs=1e-4)
        assert col(rec, "vel_n")[i] == pytest.approx(v_enu[1], abs=1e-4)
        assert col(rec, "vel_d")[i] == pytest.approx(-v_enu[2], abs=1e-4)
    assert col(rec, "gnss_fix") == [5] * 4 and col(rec, "rtk_q") == [2] * 4
    assert col(rec, "gnss_ratio") == [2.1] * 4


def test_dms_southern_latitudes_and_sdue_label(tmp_path):
    head = (
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)\n"
        "%  UTC                    latitude(d'\")  longitude(d'\")  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)"
        "  sdne(m)  sdeu(m)  sdue(m) age(s)  ratio\n"
    )
    body = (
        "2026/01/05 13:00:00.000  -33 51 59.25600  151 12 20.73600   58.3000   4  10   0.3000   0.2000   0.6000"
        "   0.0100   0.0200  -0.0300   1.50    0.0\n"
        "2026/01/05 13:00:01.000   -0 30 00.00000   -0 15 00.00000   10.0000   3   8   0.5000   0.4000   0.9000"
        "   0.0000   0.0000   0.0000   2.00    0.0\n"
    )
    p = tmp_path / "dms.pos"
    p.write_text(head + body)
    rec = rtklib.read(p, Options())
    assert col(rec, "lat") == pytest.approx([-(33 + 51 / 60 + 59.256 / 3600), -0.5], abs=1e-12)
    assert col(rec, "lon") == pytest.approx([151 + 12 / 60 + 20.736 / 3600, -0.25], abs=1e-12)
    assert col(rec, "gnss_sdun") == pytest.approx([-0.03, 0.0])
    assert col(rec, "gnss_fix") == [2, 2]  # dgps and sbas are both differential
    assert col(rec, "gnss_age") == [1.5, 2.0]


def test_bad_lines_skipped_and_counted(tmp_path):
    p = llh_file(tmp_path, vel=False)
    p.write_text(
        p.read_text() + "2026/01/05 13:00:19.000  47.4 10.2\nnot a solution line at all 1 2 3 4 5 6 7 8 9 10 11\n"
    )
    rec = rtklib.read(p, Options())
    assert len(rec.streams[0].t) == 5
    assert rec.warnings == ["skipped 2 of 7 solution line(s) that do not match the column header (15 values expected)"]


def test_refused_inputs(tmp_path):
    enu = tmp_path / "enu.pos"
    enu.write_text(
        "%  GPST                  e-baseline(m)  n-baseline(m)  u-baseline(m)   Q  ns\n2026/01/05 13:00:00.000 1 2 3 1 5\n"
    )
    with pytest.raises(InputError, match="e/n/u-baseline"):
        rtklib.read(enu, Options())
    nohead = tmp_path / "nohead.pos"
    nohead.write_text("% just a comment\n2026/01/05 13:00:00.000 47.4 10.2 900 1 5\n")
    with pytest.raises(InputError, match="no RTKLIB column header"):
        rtklib.read(nohead, Options())
    tokyo = llh_file(tmp_path, height="ellipsoidal", name="tokyo.pos")
    tokyo.write_text(tokyo.read_text().replace("height=WGS84", "height=Tokyo"))
    with pytest.raises(InputError, match="Tokyo datum"):
        rtklib.read(tokyo, Options())


def test_sniff(tmp_path):
    head = llh_file(tmp_path).read_bytes()[:4096]
    assert rtklib.sniff(Path("run.pos"), head)
    assert rtklib.sniff(Path("run.txt"), head)
    assert rtklib.sniff(Path("a.pos"), b"% anything\n")
    assert not rtklib.sniff(Path("a.txt"), b"% a matlab comment about UTC\n1 2 3\n")
    assert not rtklib.sniff(Path("a.pos"), b"$GPGGA,1*00\n")


@pytest.mark.parametrize("force", [[], ["--format", "rtklib"]], ids=["sniffed", "forced"])
def test_ingest_command(tmp_path, force):
    if not force and any(importlib.util.find_spec(f"sportfusion.ingest.{f}") is None for f in FORMATS):
        pytest.skip("a sibling reader module of sportfusion.ingest is missing, so formats cannot be sniffed")
    pos = llh_file(tmp_path)
    out = tmp_path / "out.parquet"
    proc = subprocess.run([str(BIN / "ingest"), *force, str(pos), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    assert table.num_rows == 5
    assert str(table.schema.field("rtk_q").type) == "int16"
    assert table.schema.field("rtk_q").metadata[b"unit"] == b"1"
    assert table.column("gnss_fix").to_pylist() == [4, 5, 5, 4, 1]
    assert meta["sources"][0]["time_system"] == "GPST"


def test_my_three_sniffers_claim_only_their_own(tmp_path):
    from sportfusion.ingest import gpx, nmea

    heads = {
        "rtklib": llh_file(tmp_path).read_bytes(),
        "nmea": b"$GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*4C\r\n",
        "gpx": b'<?xml version="1.0"?>\n<gpx version="1.1" creator="x">',
    }
    for fmt, head in heads.items():
        for name in ("x.pos", "x.nmea", "x.gpx"):
            claims = {m.__name__.rsplit(".", 1)[-1] for m in (rtklib, nmea, gpx) if m.sniff(Path(name), head)}
            assert claims == {fmt}, (fmt, name, claims)


# --- end to end: a carrier-phase solution with a float period through ingest -> gps2hill -> spline-smooth ---

SITE = (46.4975, 9.8365, 2200.0)  # origin of the course frame: lat [deg], lon [deg], h [m]
AZIMUTH = 160.0  # course-frame x axis, clockwise from north [deg]
FLOAT = slice(80, 120)  # epochs 8.0-11.9 s are float


def _course_truth(t):
    """A smooth downhill track in the course frame [m]: 15 m/s along x, 4 m turns, 30 % slope."""
    x = 15.0 * t
    y = 4.0 * np.sin(2 * np.pi * t / 4.0)
    z = 0.3 * x
    return np.column_stack([x, y, z])


def _e2e_pos(tmp_path, q_float: int, name: str) -> tuple[Path, np.ndarray, np.ndarray]:
    """A 10 Hz llh .pos in GPST with velocity columns and comment lines; float epochs shifted 0.4 m."""
    from sportfusion.core.frames import Frame

    t = np.arange(0.0, 20.0, 0.1)
    truth = _course_truth(t)
    meas = truth.copy()
    meas[FLOAT] += [0.3, -0.25, -0.2]  # the float solution's offset [m] in x, y, z
    lat, lon, h = Frame(*SITE, AZIMUTH).to_geodetic(meas[:, 0], meas[:, 1], meas[:, 2])
    q = np.ones(t.size, int)
    q[FLOAT] = q_float
    lines = [LLH_HEAD.format(height="ellipsoidal").rstrip("\n"), LLH_COLS.format(time="GPST") + VEL_COLS]
    start = dt.datetime(2026, 2, 10, 10, 0, 18)
    for i, ti in enumerate(t):
        if i in (50, 100):
            lines.append("% comment: reference station message gap")
        when = start + dt.timedelta(seconds=round(ti, 1))
        stamp = when.strftime("%Y/%m/%d %H:%M:%S.") + f"{when.microsecond // 1000:03d}"
        # the same reported sigmas for fixed and float: only Q tells them apart
        sd = (0.01, 0.01, 0.02, 0.0, 0.0, 0.0)
        vel = (0.0,) * 9
        lines.append(llh_line(stamp, lat[i], lon[i], h[i], int(q[i]), 12, sd, 1.0, 5.0, vel))
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p, truth, meas


def _pipeline(pos: Path, tmp_path: Path, *smooth_args: str) -> tuple[np.ndarray, np.ndarray]:
    """ingest | gps2hill | spline-smooth on the console scripts; (fix codes, smoothed x y z [m])."""
    out = tmp_path / f"{pos.stem}{'-'.join(smooth_args)}.parquet"
    cmd = (
        f"'{BIN / 'ingest'}' --format rtklib '{pos}' | '{BIN / 'gps2hill'}' --origin {SITE[0]},{SITE[1]},{SITE[2]} "
        f"--azimuth {AZIMUTH} | '{BIN / 'spline-smooth'}' {' '.join(smooth_args)} -o '{out}'"
    )
    proc = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, _ = sfio.read_table(out, kind="session")
    fix = np.asarray(table.column("gnss_fix").to_pylist())
    xyz = np.column_stack([table.column(c).to_numpy() for c in ("x", "y", "z")])
    return fix, xyz


def test_float_period_gets_lower_weight_end_to_end(tmp_path):
    pos_float, truth, meas = _e2e_pos(tmp_path, 2, "float.pos")
    pos_fixed, _, _ = _e2e_pos(tmp_path, 1, "fixed.pos")
    fix, eq6 = _pipeline(pos_float, tmp_path)
    assert (fix[FLOAT] == 5).all() and (np.delete(fix, np.r_[FLOAT]) == 4).all()
    _, all_fixed = _pipeline(pos_fixed, tmp_path)  # the same positions, every epoch flagged fixed
    _, uniform = _pipeline(pos_float, tmp_path, "--weighting", "uniform")
    # gps2hill puts the positions back into the course frame (< 1 mm)
    resid = {k: np.linalg.norm(v - meas, axis=1) for k, v in (("eq6", eq6), ("fixed", all_fixed), ("uni", uniform))}
    # 1. weight: flagged float, the spline leans far less on those epochs than when the same data is flagged fixed
    assert resid["eq6"][FLOAT].mean() > 2 * resid["fixed"][FLOAT].mean()  # measured: 3.0x
    # 2. the transition epochs (w_trans = 1e-4) are let go: the spline stays on the fixed track at the
    #    borders of the float period, where uniform weights smear the 0.45 m jump
    err_eq6 = np.linalg.norm(eq6 - truth, axis=1)
    err_uni = np.linalg.norm(uniform - truth, axis=1)
    borders = np.r_[FLOAT.start, FLOAT.stop - 1]
    assert err_eq6[borders].max() < 0.6 * err_uni[borders].min()  # measured: 0.12 m vs 0.29 m
    # 3. away from the float period the fit is the fixed track within 3 cm
    far = np.r_[0:70, 130:200]
    assert err_eq6[far].max() < 0.03  # measured: 2.1 cm (smoothing bias of lambda 0.9 on 4 m turns)


def test_xyz_utc_without_velocity(tmp_path):
    lat, lon, h = 46.4975, 9.8365, 2200.0
    head = "%  UTC                       x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio"
    rows = []
    qs = [1, 2, 5, 6]
    for i, q in enumerate(qs):
        x, y, z = pymap3d.geodetic2ecef(lat + 1e-5 * i, lon, h)
        rows.append(
            f"2026/02/10 10:00:0{i}.500 {x:14.4f} {y:14.4f} {z:14.4f} {q:3d} {10 + i:3d}"
            + "".join(f" {v:8.4f}" for v in (0.02, 0.02, 0.02, 0.0, 0.0, 0.0))
            + f" {0.5 * i:6.2f} {3.0 + i:6.1f}"
        )
    p = tmp_path / "xyz_utc.pos"
    p.write_text("% (x/y/z-ecef=WGS84,Q=1:fix,2:float,...)\n" + head + "\n% a comment\n" + "\n".join(rows) + "\n")
    rec = rtklib.read(p, Options())
    assert rec.epoch_utc == calendar.timegm((2026, 2, 10, 10, 0, 0))  # UTC: no leap seconds taken off
    assert rec.streams[0].t == pytest.approx([0.5, 1.5, 2.5, 3.5], abs=1e-9)
    assert col(rec, "gnss_fix") == [4, 5, 1, 1]  # fix -> RTK fixed, float -> RTK float, single and ppp -> GPS
    assert col(rec, "rtk_q") == qs
    assert col(rec, "gnss_sats") == [10, 11, 12, 13]
    # an isotropic 2 cm ECEF sigma stays 2 cm in north/east/up, with zero covariances
    for name in ("gnss_sigma_n", "gnss_sigma_e", "gnss_sigma_v", "gnss_sigma_h"):
        assert col(rec, name) == pytest.approx([0.02] * 4, abs=1e-6)
    assert col(rec, "gnss_sdne") == pytest.approx([0.0] * 4, abs=1e-6)
    assert col(rec, "gnss_age") == [0.0, 0.5, 1.0, 1.5] and col(rec, "gnss_ratio") == [3.0, 4.0, 5.0, 6.0]
    assert col(rec, "lat") == pytest.approx(lat + 1e-5 * np.arange(4), abs=5e-9)
    assert col(rec, "h") == pytest.approx([h] * 4, abs=1e-3)
    assert "vel_n" not in rec.streams[0].columns


ENU_HEAD = """\
% program   : RNX2RTKP ver.2.4.3 b34
% inp file  : rover.obs
% obs start : 2026/01/05 13:00:18.0 GPST (week2400 133218.0s)
% pos mode  : Kinematic
% ref pos   :  46.497500000    9.836500000  2210.1234
%
% (e/n/u-baseline=WGS84,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)
%  GPST                  e-baseline(m)  n-baseline(m)  u-baseline(m)   Q  ns   sde(m)   sdn(m)   sdu(m)  sden(m)  sdnu(m)  sdue(m) age(s)  ratio
"""
BASE = (46.4975, 9.8365, 2210.1234)


def enu_file(tmp_path, head=ENU_HEAD, name="enu.pos"):
    """Rover positions a few hundred metres to 3 km from the base, as RTKLIB's outenu writes them (%14.4f ...)."""
    rng = np.random.default_rng(8)
    truth = []
    rows = []
    for i in range(6):
        lat = BASE[0] + rng.uniform(-0.02, 0.02)
        lon = BASE[1] + rng.uniform(-0.03, 0.03)
        h = BASE[2] + rng.uniform(-300, 50)
        e, n, u = pymap3d.geodetic2enu(lat, lon, h, *BASE)  # independent of the reader's pyproj pipeline
        sd = (0.004, 0.005, 0.012, 0.001, -0.002, 0.003)
        rows.append(
            f"2026/01/05 13:00:{18 + i:02d}.000 {e:14.4f} {n:14.4f} {u:14.4f} {1:3d} {12:3d}"
            + "".join(f" {v:8.4f}" for v in sd)
            + f" {0.0:6.2f} {55.3:6.1f}"
        )
        truth.append((lat, lon, h))
    p = tmp_path / name
    p.write_text(head + "\n".join(rows) + "\n")
    return p, np.array(truth)


def test_enu_baseline_with_ref_pos_header(tmp_path):
    p, truth = enu_file(tmp_path)
    assert rtklib.sniff(p, p.read_bytes()[:4096])
    rec = rtklib.read(p, Options())
    lat, lon, h = (np.array(col(rec, c)) for c in ("lat", "lon", "h"))
    # the file rounds baselines to 0.1 mm: positions agree with the truth to that
    e, n, u = pymap3d.geodetic2enu(lat, lon, h, truth[:, 0], truth[:, 1], truth[:, 2])
    assert np.max(np.abs([e, n, u])) < 2e-4  # [m]
    assert col(rec, "gnss_fix") == [4] * 6 and col(rec, "gnss_sats") == [12] * 6
    assert col(rec, "gnss_sigma_e")[0] == 0.004 and col(rec, "gnss_sigma_n")[0] == 0.005
    assert col(rec, "gnss_sigma_v")[0] == 0.012
    assert (
        col(rec, "gnss_sdne")[0] == 0.001 and col(rec, "gnss_sdun")[0] == -0.002 and col(rec, "gnss_sdeu")[0] == 0.003
    )
    assert rec.meta["base"] == {"lat": BASE[0], "lon": BASE[1], "h": BASE[2]}


def test_enu_baseline_base_from_option_or_refused(tmp_path):
    head = "\n".join(ln for ln in ENU_HEAD.splitlines() if "ref pos" not in ln) + "\n"
    p, truth = enu_file(tmp_path, head=head)
    with pytest.raises(InputError, match="--base LAT,LON,H"):
        rtklib.read(p, Options())
    rec = rtklib.read(p, Options(base=BASE))
    assert np.allclose(col(rec, "lat"), truth[:, 0], atol=1e-8) and np.allclose(col(rec, "h"), truth[:, 2], atol=2e-4)
    # --base beats the header and says so
    q, _ = enu_file(tmp_path, name="other.pos")
    rec = rtklib.read(q, Options(base=(BASE[0], BASE[1], BASE[2] + 10.0)))
    assert np.allclose(np.array(col(rec, "h")) - truth[:, 2], 10.0, atol=1e-3)
    assert any("instead of the header's ref pos" in w for w in rec.warnings)


def test_ingest_base_option(tmp_path):
    head = "\n".join(ln for ln in ENU_HEAD.splitlines() if "ref pos" not in ln) + "\n"
    p, truth = enu_file(tmp_path, head=head)
    r = subprocess.run([str(BIN / "ingest"), str(p), "--base", "46.4975,9.8365,2210.1234"], capture_output=True)
    assert r.returncode == 0, r.stderr.decode()
    table = sfio.table_from_bytes(r.stdout)
    assert np.allclose(table.column("lat").to_numpy(), truth[:, 0], atol=1e-8)
    bad = subprocess.run([str(BIN / "ingest"), str(p), "--base", "46.4,9.8"], capture_output=True)
    assert bad.returncode == 2 and b"--base" in bad.stderr


def test_no_solution_and_ecef_origin_are_null(tmp_path):
    """Q = 0 (RTKLIB's SOLQ_NONE) and the ECEF origin (an empty solution; lat -90, lon 0, height -6378137 m in
    llh) are no positions: position, velocity and sigmas null, Q kept, one warning; nothing else changes."""
    lines = [LLH_HEAD.format(height="ellipsoidal").rstrip("\n"), LLH_COLS.format(time="GPST") + VEL_COLS]
    rows = [  # (q, lat, lon, h)
        (1, 47.4049, 10.2945, 960.2),
        (0, 47.4049, 10.2945, 960.2),  # no solution, the last position repeated
        (5, -90.0, 0.0, -6378137.0),  # the ECEF origin written as geodetic coordinates
        (1, 47.40491, 10.2945, 960.3),
    ]
    for i, (q, lat, lon, h) in enumerate(rows):
        stamp = f"2026/01/05 13:00:{18 + i:02d}.000"
        lines.append(llh_line(stamp, lat, lon, h, q, 12, SD[0], 1.0, 5.0, (3.0, 4.0, 0.5, 0.01, 0.02, 0.03, 0, 0, 0)))
    p = tmp_path / "none.pos"
    p.write_text("\n".join(lines) + "\n")
    rec = rtklib.read(p, Options())
    assert col(rec, "rtk_q") == [1, 0, 5, 1] and col(rec, "gnss_fix") == [4, 0, 1, 4]
    for name in ("lat", "lon", "h", "vel_n", "vel_e", "vel_d", "gnss_sigma_h", "std_vel_n", "gnss_sdne"):
        v = col(rec, name)
        assert v[1] is None and v[2] is None, name
        assert v[0] is not None and v[3] is not None, name
    assert col(rec, "lat")[3] == pytest.approx(47.40491, abs=1e-10)
    assert col(rec, "gnss_sats") == [12] * 4
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    assert "1 with Q = 0" in line and "1 at the Earth's centre" in line and "2 of 4 epoch(s)" in line
    # ECEF xyz: the origin itself
    head = "%  UTC                       x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio"
    x, y, z = pymap3d.geodetic2ecef(46.4975, 9.8365, 2200.0)
    body = [
        f"2026/02/10 10:00:00.000 {x:14.4f} {y:14.4f} {z:14.4f}   1  10" + " 0.0200" * 6 + "   0.00    3.0",
        f"2026/02/10 10:00:01.000 {0:14.4f} {0:14.4f} {0:14.4f}   5  10" + " 0.0200" * 6 + "   0.00    3.0",
    ]
    p = tmp_path / "xyz0.pos"
    p.write_text(head + "\n" + "\n".join(body) + "\n")
    rec = rtklib.read(p, Options())
    assert col(rec, "lat")[1] is None and col(rec, "h")[1] is None and col(rec, "gnss_sigma_n")[1] is None
    assert col(rec, "lat")[0] == pytest.approx(46.4975, abs=1e-8)
    assert any("1 at the Earth's centre" in w for w in rec.warnings)
