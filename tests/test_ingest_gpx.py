"""GPX reader: tracks, times, elevations and the geoid offset, on files written here."""

from __future__ import annotations

import calendar
import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.ingest import FORMATS, Options, combine, gpx

BIN = Path(sys.executable).parent

HEAD = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1" '
    'xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v2">\n'
)


def trkpt(lat, lon, ele=None, time=None, extra=""):
    inner = ""
    if ele is not None:
        inner += f"<ele>{ele}</ele>"
    if time is not None:
        inner += f"<time>{time}</time>"
    return f'<trkpt lat="{lat}" lon="{lon}">{inner}{extra}</trkpt>\n'


def write(tmp_path: Path, segments: list[list[str]], extra: str = "", name: str = "track.gpx") -> Path:
    body = "".join("<trkseg>\n" + "".join(seg) + "</trkseg>\n" for seg in segments)
    p = tmp_path / name
    p.write_text(HEAD + extra + "<trk><name>run</name>" + body + "</trk>\n</gpx>\n")
    return p


def col(rec, name):
    v = rec.streams[0].columns[name]
    if hasattr(v, "to_pylist"):
        return v.to_pylist()
    return [None if np.isnan(x) else float(x) for x in v]


EXT = (
    "<sat>9</sat><hdop>0.8</hdop><fix>{fix}</fix>"
    "<extensions><gpxtpx:TrackPointExtension><gpxtpx:speed>{speed}</gpxtpx:speed>"
    "<gpxtpx:course>{course}</gpxtpx:course></gpxtpx:TrackPointExtension></extensions>"
)


def timed_track(tmp_path):
    seg1 = [
        trkpt(47.4049, 10.2945, 912.5, "2026-01-05T13:00:00Z", EXT.format(fix="3d", speed=10.0, course=90.0)),
        trkpt(47.4050, 10.2946, 913.0, "2026-01-05T13:00:00.500Z", EXT.format(fix="dgps", speed=12.0, course=0.0)),
    ]
    seg2 = [
        trkpt(47.4051, 10.2947, None, "2026-01-05T13:00:01.500Z", EXT.format(fix="none", speed=5.0, course=180.0)),
        trkpt(47.4052, 10.2948, 914.0, "2026-01-05T14:00:02+01:00", EXT.format(fix="pps", speed=4.0, course=270.0)),
    ]
    waypoint = '<wpt lat="1" lon="2"><time>2020-01-01T00:00:00Z</time></wpt>\n'
    return write(tmp_path, [seg1, seg2], extra=waypoint)


def test_track_with_times_segments_and_extensions(tmp_path):
    rec = gpx.read(timed_track(tmp_path), Options())
    (s,) = rec.streams
    assert rec.epoch_utc == calendar.timegm((2026, 1, 5, 13, 0, 0))
    assert s.t.tolist() == [0.0, 0.5, 1.5, 2.0]  # both segments, +01:00 zone converted; the waypoint ignored
    assert col(rec, "lat") == [47.4049, 47.4050, 47.4051, 47.4052]
    assert col(rec, "h_msl") == [912.5, 913.0, None, 914.0]  # missing <ele> -> null
    assert "h" not in s.columns  # no geoid offset: ellipsoidal h unknown, so no h column (MSL only)
    assert col(rec, "label") == ["run"] * 4  # the track's <name>
    assert sum("--geoid-offset" in w for w in rec.warnings) == 1
    assert col(rec, "gnss_fix") == [1, 2, 0, 3]
    assert col(rec, "gnss_sats") == [9] * 4
    assert col(rec, "gnss_hdop") == [0.8] * 4
    assert col(rec, "gnss_speed") == [10.0, 12.0, 5.0, 4.0]
    assert col(rec, "vel_n") == pytest.approx([0.0, 12.0, -5.0, 0.0], abs=1e-12)
    assert col(rec, "vel_e") == pytest.approx([10.0, 0.0, 0.0, -4.0], abs=1e-12)
    assert rec.meta["segments"] == 2


def test_geoid_offset_applied(tmp_path):
    rec = gpx.read(timed_track(tmp_path), Options(geoid_offset=47.9))
    h = col(rec, "h")
    assert h[2] is None  # no <ele>
    assert [h[0], h[1], h[3]] == pytest.approx([912.5 + 47.9, 913.0 + 47.9, 914.0 + 47.9], abs=1e-9)
    assert col(rec, "h_msl")[0] == 912.5
    assert not any("--geoid-offset" in w for w in rec.warnings)


def test_geoidheight_element_used_without_option(tmp_path):
    p = write(tmp_path, [[trkpt(1, 2, 100.0, "2026-01-05T13:00:00Z", "<geoidheight>48.5</geoidheight>")]])
    assert col(gpx.read(p, Options()), "h") == [148.5]
    assert col(gpx.read(p, Options(geoid_offset=40.0)), "h") == [140.0]  # the option wins


def test_points_without_time_error_and_no_time_mode(tmp_path):
    p = write(tmp_path, [[trkpt(1, 2, 5.0, "2026-01-05T13:00:00Z"), trkpt(1.1, 2, 6.0), trkpt(1.2, 2, 7.0)]])
    with pytest.raises(InputError, match=r"2 of 3 track point\(s\) have no <time>.*--no-time"):
        gpx.read(p, Options())
    rec = gpx.read(p, Options(no_time=True))
    assert rec.epoch_utc is None
    assert rec.streams[0].t.tolist() == [0.0, 1.0, 2.0]
    assert col(rec, "h_msl") == [5.0, 6.0, 7.0]
    assert any("--no-time" in w for w in rec.warnings)


def test_identical_times_error(tmp_path):
    same = "2026-01-05T13:00:00Z"
    p = write(tmp_path, [[trkpt(1, 2, 5.0, same), trkpt(1.1, 2, 5.0, same), trkpt(1.2, 2, 5.0, same)]])
    with pytest.raises(InputError, match="all 3 track points have the same time.*--no-time"):
        gpx.read(p, Options())
    assert gpx.read(p, Options(no_time=True)).streams[0].t.tolist() == [0.0, 1.0, 2.0]


def test_backwards_time_and_exact_repeat_are_read_and_ordered_by_the_merge(tmp_path):
    # was refused before issue 15: a time stepping back is now ordered by ingest's one policy
    back = [trkpt(1, 2, 5.0, "2026-01-05T13:00:01Z"), trkpt(1.1, 2, 5.0, "2026-01-05T13:00:00Z")]
    rec = gpx.read(write(tmp_path, [back]), Options())
    assert rec.streams[0].t.tolist() == [1.0, 0.0]  # absolute time kept: the earliest point is the epoch
    table, meta, _ = combine([rec])
    assert table.column("t").to_pylist() == [0.0, 1.0]
    assert table.column("lat").to_pylist() == [1.1, 1.0]
    assert meta["sources"][0]["time_order"]["gpx"]["backward_steps"] == 1
    a, b = trkpt(1, 2, 5.0, "2026-01-05T13:00:00Z"), trkpt(1.1, 2, 5.0, "2026-01-05T13:00:01Z")
    rec = gpx.read(write(tmp_path, [[a, b], [b, trkpt(1.2, 2, 5.0, "2026-01-05T13:00:02Z")]]), Options())
    assert rec.streams[0].t.tolist() == [0.0, 1.0, 1.0, 2.0]  # the repeat is folded by the merge
    table, meta, _ = combine([rec])
    assert table.num_rows == 3 and meta["sources"][0]["time_order"]["gpx"]["duplicates_dropped"] == 1


def test_no_elevation_at_all(tmp_path):
    p = write(tmp_path, [[trkpt(1, 2, None, "2026-01-05T13:00:00Z"), trkpt(1.1, 2, None, "2026-01-05T13:00:01Z")]])
    rec = gpx.read(p, Options(geoid_offset=47.9))
    assert "h" not in rec.streams[0].columns and "h_msl" not in rec.streams[0].columns  # a 2-D track
    assert any("2-D track" in w for w in rec.warnings)


def test_routes_only_and_broken_xml(tmp_path):
    p = tmp_path / "route.gpx"
    p.write_text(HEAD + '<rte><rtept lat="1" lon="2"/></rte><wpt lat="1" lon="2"/></gpx>\n')
    with pytest.raises(InputError, match=r"no track points.*1 route point\(s\) and 1 waypoint"):
        gpx.read(p, Options())
    broken = tmp_path / "broken.gpx"
    broken.write_text(HEAD + "<trk><trkseg><trkpt lat=")
    with pytest.raises(InputError, match="not a readable GPX file"):
        gpx.read(broken, Options())


def test_sniff():
    assert gpx.sniff(Path("a.xml"), HEAD.encode())
    assert not gpx.sniff(Path("a.gpx"), b"$GPGGA,1*00\n")


@pytest.mark.parametrize("force", [[], ["--format", "gpx"]], ids=["sniffed", "forced"])
def test_ingest_command(tmp_path, force):
    if not force and any(importlib.util.find_spec(f"sportfusion.ingest.{f}") is None for f in FORMATS):
        pytest.skip("a sibling reader module of sportfusion.ingest is missing, so formats cannot be sniffed")
    track = timed_track(tmp_path)
    out = tmp_path / "out.parquet"
    cmd = [str(BIN / "ingest"), *force, str(track), "--geoid-offset", "47.9", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, _ = sfio.read_table(out, kind="session")
    assert table.num_rows == 4
    assert table.column("h").to_pylist()[0] == pytest.approx(912.5 + 47.9)
    # no times: one error line, nothing written; --no-time reads it
    untimed = write(tmp_path, [[trkpt(1, 2, 5.0), trkpt(1.1, 2, 6.0)]], name="untimed.gpx")
    proc = subprocess.run([str(BIN / "ingest"), *force, str(untimed)], capture_output=True, timeout=120)
    assert proc.returncode == 1 and proc.stdout == b""
    err = proc.stderr.decode().strip().splitlines()
    assert len(err) == 1 and err[0].startswith("Error: ingest:") and "--no-time" in err[0]
    proc = subprocess.run([str(BIN / "ingest"), *force, str(untimed), "--no-time", "-o", str(out)], capture_output=True)
    assert proc.returncode == 0, proc.stderr.decode()
    assert sfio.read_table(out)[0].column("t").to_pylist() == [0.0, 1.0]


# --- real-export quirks (issue 15 items 1-2, issue 17) ----------------------------------------------------


def _watch_track(n: int = 3000) -> tuple[list[str], list[tuple[float, float, float]]]:
    """A 1 Hz watch track descending a slope, with one backwards second at point 1500 (its clock hiccups)."""
    pts, where = [], []
    for i in range(n):
        sec = i - 2 if i == 1500 else i  # point 1500 carries the time of point 1498: one step back
        lat, lon, ele = 47.40 + 8e-5 * i, 10.29 + 5e-5 * np.sin(i / 40.0), 1800.0 - 0.3 * i
        hh, mm, ss = 9 + sec // 3600, sec // 60 % 60, sec % 60
        pts.append(trkpt(f"{lat:.7f}", f"{lon:.7f}", f"{ele:.1f}", f"2026-02-01T{hh:02d}:{mm:02d}:{ss:02d}Z"))
        where.append((lat, lon, ele))
    return pts, where


def test_watch_gpx_with_one_backwards_second_ingests(tmp_path):
    pts, _ = _watch_track()
    track = write(tmp_path, [pts], name="watch.gpx")
    out = tmp_path / "w.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(track), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    err = proc.stderr.decode()
    info = [ln for ln in err.splitlines() if "rows from" in ln]
    assert len(info) == 1 and "1 backward steps" in info[0] and "1 same time conflicts" in info[0], err
    assert "index 1500 at t = 1498.000 s" in err  # the conflicting point is named
    table, meta = sfio.read_table(out, kind="session")
    t = table.column("t").to_numpy()
    assert table.num_rows == 2999 and np.all(np.diff(t) > 0)
    # the first point at 1498 s (file order) wins; nothing else is lost
    lat = table.column("lat").to_numpy()
    assert lat[1498] == pytest.approx(47.40 + 8e-5 * 1498) and lat[1499] == pytest.approx(47.40 + 8e-5 * 1499)
    order = meta["provenance"][-1]["params"]["time_order"]
    assert order["backward_steps"] == 1 and order["same_time_conflicts"] == 1 and order["samples"] == 3000
    assert meta["sources"][0]["time_order"]["gpx"]["reordered"] == 2  # points 1499 and 1500 swapped
    assert "h" not in table.column_names and table.schema.field("h_msl").metadata[b"height_ref"] == b"msl"
    # the 3-D length of what was ingested against gpxpy's own length_3d of the file (an independent reader)
    import gpxpy
    from pyproj import Geod

    ref = gpxpy.parse(track.read_text()).length_3d()
    lon = table.column("lon").to_numpy()
    _, _, d2 = Geod(ellps="WGS84").inv(lon[:-1], lat[:-1], lon[1:], lat[1:])
    length = np.hypot(d2, np.diff(table.column("h_msl").to_numpy())).sum()
    assert length == pytest.approx(ref, rel=2e-3)


def test_track_names_become_a_label_column(tmp_path):
    trk = "".join(
        f"<trk><name>{name}</name><trkseg>"
        + trkpt(47.4 + j * 1e-3, 10.3, 1000.0, f"2026-02-01T10:00:0{j}Z")
        + trkpt(47.4 + j * 1e-3 + 5e-4, 10.3, 1000.0, f"2026-02-01T10:00:0{j}.5Z")
        + "</trkseg></trk>\n"
        for j, name in enumerate(["Lift", "Downhill", "Hold"])
    )
    p = tmp_path / "ski.gpx"
    p.write_text(HEAD + trk + '<trk><trkseg><trkpt lat="47.41" lon="10.3"><time>2026-02-01T10:00:05Z</time></trkpt>'
                 "</trkseg></trk></gpx>\n")  # fmt: skip
    rec = gpx.read(p, Options())
    assert col(rec, "label") == ["Lift", "Lift", "Downhill", "Downhill", "Hold", "Hold", None]
    table, _, _ = combine([rec])
    assert table.schema.field("label").type == pa.string()


def test_latitude_out_of_range_is_refused_in_one_line(tmp_path):
    p = write(
        tmp_path, [[trkpt(47.0, 10.0, 5.0, "2026-01-05T13:00:00Z"), trkpt(91.5, 10.0, 5.0, "2026-01-05T13:00:01Z")]]
    )
    with pytest.raises(InputError, match=r"track point 1 has latitude 91.5.*expected latitude -90..90"):
        gpx.read(p, Options())
    proc = subprocess.run([str(BIN / "ingest"), str(p)], capture_output=True, timeout=120)
    lines = proc.stderr.decode().strip().splitlines()
    assert proc.returncode == 1 and proc.stdout == b"" and len(lines) == 1 and "latitude 91.5" in lines[0]


def test_height_from_vendor_extensions_and_untimed_points_dropped_with_a_warning(tmp_path):
    ext = "<extensions><app:{0}>{1}</app:{0}></extensions>"
    seg = [
        trkpt(47.0, 10.0, None, "2026-01-05T13:00:00Z", ext.format("altitude", 900.0)),  # MSL by convention
        trkpt(47.0001, 10.0, None, "2026-01-05T13:00:01Z", ext.format("ellipsoidalAltitude", 950.0)),
        trkpt(47.0002, 10.0, 902.0, None),  # no time: dropped, named
        trkpt(47.0003, 10.0, 903.0, "2026-01-05T13:00:03Z"),
    ]
    p = tmp_path / "phone.gpx"
    p.write_text(
        HEAD.replace("<gpx ", '<gpx xmlns:app="urn:x-app" ') + "<trk><trkseg>" + "".join(seg) + "</trkseg></trk></gpx>"
    )
    rec = gpx.read(p, Options())
    assert col(rec, "h_msl") == [900.0, None, 902.0, 903.0]
    assert col(rec, "h") == [None, 950.0, None, None]
    table, _, warnings = combine([rec])
    assert table.num_rows == 3
    assert any("1 sample(s) without a finite time dropped (first index: 2)" in w for w in warnings)


def test_accuracy_extensions_and_invalid_markers(tmp_path):
    """A phone logger's accuracy extensions become sigmas (68 % radius / 1.5096); -1 speed/course and a
    negative accuracy (iOS: invalid fix) are nulls; HDOP 99.99 is no value."""
    pts = [
        trkpt(47.1, 9.5, 500.0, "2026-01-27T10:00:00Z",
              "<hdop>99.99</hdop><extensions><hAcc>7.548</hAcc><vAcc>4.0</vAcc><speed>-1</speed><course>-1</course></extensions>"),
        trkpt(47.10001, 9.5, 501.0, "2026-01-27T10:00:01Z",
              "<hdop>1.2</hdop><extensions><hAcc>-1</hAcc><vAcc>-1</vAcc><speed>1.5</speed><course>90</course></extensions>"),
        trkpt(47.10002, 9.5, 502.0, "2026-01-27T10:00:02Z",
              "<extensions><accuracy>3.0192</accuracy><speed>1.6</speed><course>-1</course></extensions>"),
    ]  # fmt: skip
    rec = gpx.read(write(tmp_path, [pts]), Options())
    sh = col(rec, "gnss_sigma_h")
    assert sh[0] == pytest.approx(7.548 / 1.5096, rel=1e-4) and sh[1] is None and sh[2] == pytest.approx(2.0, rel=1e-4)
    assert col(rec, "gnss_sigma_v")[0] == 4.0
    assert col(rec, "lat")[1] is None and col(rec, "lon")[1] is None and col(rec, "lat")[0] == 47.1
    assert col(rec, "h_msl")[1] is None and col(rec, "h_msl")[2] == 502.0
    assert col(rec, "gnss_speed") == [None, 1.5, 1.6] and col(rec, "gnss_course") == [None, 90.0, None]
    assert col(rec, "vel_e")[1] == pytest.approx(1.5) and col(rec, "vel_n")[0] is None and col(rec, "vel_n")[2] is None
    assert col(rec, "gnss_hdop") == [None, 1.2, None]
