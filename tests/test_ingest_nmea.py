"""NMEA 0183 reader: values hand-computed from the sentences written here."""

from __future__ import annotations

import calendar
import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.ingest import FORMATS, Options, nmea, read_recording

BIN = Path(sys.executable).parent
KNOT = 1852.0 / 3600.0


def sentence(body: str) -> str:
    """``$body*hh`` with the XOR checksum of the body."""
    cs = 0
    for ch in body.encode():
        cs ^= ch
    return f"${body}*{cs:02X}"


def write(tmp_path: Path, bodies: list[str], name: str = "log.nmea") -> Path:
    p = tmp_path / name
    p.write_text("\r\n".join(b if b.startswith("$") or not b else sentence(b) for b in bodies) + "\r\n")
    return p


def col(rec, name):
    v = rec.streams[0].columns[name]
    return v.to_pylist() if hasattr(v, "to_pylist") else [None if np.isnan(x) else float(x) for x in v]


# Two epochs at 10 Hz, GN and GP talkers; then a GGA with a bad checksum and a garbage line.
MIXED = [
    "GNRMC,100000.00,A,4724.2940,N,01017.6700,E,19.438,45.0,150325,,,D",
    "GNVTG,45.0,T,,M,19.438,N,36.0,K,D",
    "GNGGA,100000.00,4724.2940,N,01017.6700,E,4,14,0.7,912.35,M,47.85,M,1.0,0000",
    "GPGST,100000.00,0.02,0.015,0.010,30.0,0.012,0.016,0.030",
    "GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00",
    "GPQQQ,1,2",
    "GPGGA,100000.10,4724.2946,N,01017.6712,E,5,13,0.9,913.00,M,47.85,M,1.0,0000",
    "GPVTG,180.0,T,,M,,N,36.0,K,A",
    "GLGST,100000.10,0.2,0.15,0.10,30.0,0.30,0.40,0.50",
    "$GPGGA,100000.20,4724.2950,N,01017.6720,E,5,13,0.9,913.50,M,47.85,M,1.0,0000*00",
    "this is not a sentence",
]


def test_mixed_talkers_exact_values(tmp_path):
    rec = nmea.read(write(tmp_path, MIXED), Options())
    (s,) = rec.streams
    assert rec.epoch_utc == calendar.timegm((2025, 3, 15, 10, 0, 0))
    assert s.t.tolist() == [0.0, 0.1]  # exact: whole and fractional seconds kept apart
    # decimal minutes: 47 deg 24.2940' = 47.4049 deg, 10 deg 17.6700' = 10.2945 deg
    assert col(rec, "lat") == pytest.approx([47.4049, 47 + 24.2946 / 60], abs=1e-12)
    assert col(rec, "lon") == pytest.approx([10.2945, 10 + 17.6712 / 60], abs=1e-12)
    assert col(rec, "h") == pytest.approx([912.35 + 47.85, 913.00 + 47.85], abs=1e-9)
    assert col(rec, "h_msl") == pytest.approx([912.35, 913.00], abs=1e-9)
    assert col(rec, "gnss_fix") == [4, 5]
    assert col(rec, "gnss_sats") == [14, 13]
    assert col(rec, "gnss_hdop") == pytest.approx([0.7, 0.9])
    # GST: latitude/longitude/altitude sigmas; sigma_h = sqrt((0.012^2 + 0.016^2)/2) = sqrt(2e-4)
    assert col(rec, "gnss_sigma_n") == pytest.approx([0.012, 0.30])
    assert col(rec, "gnss_sigma_e") == pytest.approx([0.016, 0.40])
    assert col(rec, "gnss_sigma_v") == pytest.approx([0.030, 0.50])
    assert col(rec, "gnss_sigma_h") == pytest.approx([math.sqrt(2e-4), math.sqrt(0.125)], rel=1e-12)
    # epoch 1: RMC 19.438 kn at 45 deg; epoch 2: VTG 36.0 km/h = 10 m/s at 180 deg (no knots field)
    v1 = 19.438 * 1852 / 3600
    assert col(rec, "gnss_speed") == pytest.approx([v1, 10.0], rel=1e-12)
    assert col(rec, "gnss_course") == pytest.approx([45.0, 180.0])
    assert col(rec, "vel_n") == pytest.approx([v1 / math.sqrt(2), -10.0], rel=1e-12)
    assert col(rec, "vel_e") == pytest.approx([v1 / math.sqrt(2), 0.0], abs=1e-12)
    assert "vel_d" not in s.columns
    # one warning for the skipped lines, both causes counted
    skipped = [w for w in rec.warnings if "skipped" in w]
    assert len(skipped) == 1
    assert "skipped 2 of 11" in skipped[0] and "1 with a bad or missing checksum" in skipped[0]
    assert "1 unparsable" in skipped[0]
    assert rec.meta["talkers"] == ["GL", "GN", "GP"]
    assert rec.meta["ignored_sentences"] == 2  # GSV and the unknown QQQ: valid, just not used


def test_gga_without_geoid_separation_and_without_date(tmp_path):
    p = write(
        tmp_path,
        [
            "GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,,M,,",
            "GPGGA,120001.0,4807.038,N,01131.000,E,1,08,0.9,545.9,M,,M,,",
        ],
    )
    # no RMC/ZDA: a time of day alone cannot be placed in UTC -> refused, naming --date (issue 17)
    with pytest.raises(InputError, match=r"no date .*first fix at 12:00:00 UTC.*--date YYYY-MM-DD"):
        nmea.read(p, Options())
    # the date option places it in UTC
    dated = nmea.read(p, Options(date="2026-01-05"))
    assert col(dated, "h") == [None, None]
    assert col(dated, "h_msl") == pytest.approx([545.4, 545.9])
    sep = [w for w in dated.warnings if "geoid separation" in w]
    assert len(sep) == 1 and sep[0].startswith("2 fix(es)")
    with_n = nmea.read(p, Options(date="2026-01-05", geoid_offset=46.9))  # --geoid-offset fills h
    assert col(with_n, "h") == pytest.approx([545.4 + 46.9, 545.9 + 46.9], abs=1e-9)
    assert not any("geoid separation" in w for w in with_n.warnings)
    assert dated.epoch_utc == calendar.timegm((2026, 1, 5, 12, 0, 0))
    assert dated.streams[0].t.tolist() == [0.0, 1.0]
    assert not any("no date" in w for w in dated.warnings)
    with pytest.raises(InputError, match="YYYY-MM-DD"):
        nmea.read(p, Options(date="05.01.2026"))


def test_midnight_rollover(tmp_path):
    p = write(
        tmp_path,
        [
            "GPRMC,235959.50,A,4807.038,N,01131.000,E,0.0,,311224,,,A",
            "GPGGA,235959.50,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
            "GPGGA,000000.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
            "GPGGA,000000.50,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
            "GPRMC,000001.00,A,4807.038,N,01131.000,E,0.0,,010125,,,A",
        ],
    )
    rec = nmea.read(p, Options())
    assert rec.epoch_utc == calendar.timegm((2024, 12, 31, 23, 59, 59))
    assert rec.streams[0].t.tolist() == [0.5, 1.0, 1.5, 2.0]
    # speed 0 with an empty course: velocity is zero, not unknown
    assert col(rec, "vel_n")[0] == 0.0 and "gnss_course" not in rec.streams[0].columns
    # a GGA-only log across midnight keeps counting seconds
    p2 = write(tmp_path, ["GPGGA,235959.5,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
                          "GPGGA,000000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"], "b.nmea")  # fmt: skip
    assert nmea.read(p2, Options(date="2024-12-31")).streams[0].t.tolist() == [0.5, 1.0]  # epoch: whole second


def test_decimal_minutes_by_hand():
    assert nmea.dm_to_deg("4807.038", "N") == pytest.approx(48.1173, abs=1e-12)  # 48 + 7.038/60
    assert nmea.dm_to_deg("01131.000", "E") == pytest.approx(11.5166666666667, abs=1e-12)  # 11 + 31/60
    assert nmea.dm_to_deg("3351.9876", "S") == pytest.approx(-33.86646, abs=1e-12)  # -(33 + 51.9876/60)
    assert nmea.dm_to_deg("15112.3456", "W") == pytest.approx(-151.20576, abs=1e-12)
    assert nmea.dm_to_deg("0007.5", "S") == pytest.approx(-0.125, abs=1e-15)
    assert nmea.dm_to_deg("", "N") is None


def test_invalid_fix_kept_and_gns_and_rmc_only(tmp_path):
    p = write(
        tmp_path,
        [
            "GPRMC,080000.0,V,,,,,,,010626,,,N",
            "GPGGA,080000.0,,,,,0,00,,,M,,M,,",
            "GPRMC,080001.0,V,,,,,,,010626,,",
            "GNGNS,080002.0,4724.2940,N,01017.6700,E,RRN,20,0.6,912.35,47.85,1.0,0000",
            "GNZDA,080003.0,01,06,2026,00,00",
            "GNRMC,080004.0,A,4724.2940,N,01017.6700,E,1.0,90.0,010626,,,F",
        ],
    )
    rec = nmea.read(p, Options())
    assert len(rec.streams[0].t) == 5  # nothing dropped, ZDA's epoch included
    assert col(rec, "gnss_fix") == [0, 0, 4, None, 5]  # GGA 0; RMC V -> 0; GNS R -> 4; RMC mode F -> 5
    assert col(rec, "lat")[:2] == [None, None]
    assert col(rec, "h") == [None, None, pytest.approx(960.2), None, None]


def test_all_bad_is_an_error(tmp_path):
    p = write(tmp_path, ["$GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*00"])
    with pytest.raises(InputError, match="1 with a bad or missing checksum"):
        nmea.read(p, Options())


def test_sniff():
    assert nmea.sniff(Path("x.txt"), b"\r\n" + sentence("GPGGA,1,2").encode() + b"\r\n")
    assert not nmea.sniff(Path("x.nmea"), b"$GPGGA,120000.0,4807.038,N\n")  # no checksum
    assert not nmea.sniff(Path("x.gpx"), b'<?xml version="1.0"?><gpx version="1.1">')


def _all_readers() -> None:
    """Skip format sniffing while a sibling reader module of sportfusion.ingest is not written yet."""
    for fmt in FORMATS:
        if importlib.util.find_spec(f"sportfusion.ingest.{fmt}") is None:
            pytest.skip(f"sportfusion.ingest.{fmt} is missing, so formats cannot be sniffed")


@pytest.mark.parametrize("force", [[], ["--format", "nmea"]], ids=["sniffed", "forced"])
def test_ingest_command_end_to_end(tmp_path, force):
    if not force:
        _all_readers()
    log = write(tmp_path, MIXED, "gps.nmea")
    out = tmp_path / "out.parquet"
    with out.open("wb") as fh:
        proc = subprocess.run([str(BIN / "ingest"), *force, str(log)], stdout=fh, stderr=subprocess.PIPE, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"Warning: ingest:" in proc.stderr and b"skipped 2 of 11" in proc.stderr
    table, meta = sfio.read_table(out, kind="session")
    assert table.num_rows == 2
    for name in ("t", "lat", "lon", "h", "h_msl", "gnss_fix", "gnss_sigma_h", "vel_n", "vel_e"):
        assert name in table.column_names
    assert table.schema.field("h").metadata[b"unit"] == b"m"
    assert table.column("gnss_fix").to_pylist() == [4, 5]
    assert epoch_unix(meta) == calendar.timegm((2025, 3, 15, 10, 0, 0))
    assert meta["sources"][0]["format"] == "nmea"


@pytest.mark.parametrize("force", [[], ["--format", "nmea"]], ids=["sniffed", "forced"])
def test_ingest_command_corrupt_file(tmp_path, force):
    if not force:
        _all_readers()
    bad = tmp_path / "bad.nmea"
    bad.write_text("$GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*00\n$GPRMC,garbage*11\n")
    proc = subprocess.run([str(BIN / "ingest"), *force, str(bad)], capture_output=True, timeout=120)
    assert proc.returncode == 1
    assert proc.stdout == b""
    lines = proc.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ingest:") and "checksum" in lines[0]


def test_read_recording_sniffs_nmea(tmp_path):
    _all_readers()
    rec = read_recording(write(tmp_path, MIXED, "gps.log"))
    assert rec.format == "nmea"


def test_vtg_before_its_gga_lands_in_its_own_epoch(tmp_path):
    p = write(
        tmp_path,
        [
            "GPVTG,10.0,T,,M,1.0,N,,K,A",
            "GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
            "GPVTG,20.0,T,,M,2.0,N,,K,A",
            "GPGGA,120001.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
        ],
    )
    rec = nmea.read(p, Options(date="2026-01-05"))
    assert col(rec, "gnss_course") == [10.0, 20.0]
    assert col(rec, "gnss_speed") == pytest.approx([KNOT, 2 * KNOT])


# --- logs that do not start with NMEA (issue 15 item 3) ---------------------------------------------------


def _quirky_log(tmp_path: Path, n_sec: int = 20) -> Path:
    """A receiver test log: '#' header, 1 Hz GGA/RMC among 40 Hz proprietary $P sentences, AIS, instrument
    talkers, a logger's time prefix and bytes of an interleaved binary protocol."""
    out = bytearray()
    for i in range(120):  # a long comment header: the first 4 KiB hold no sentence at all
        out += f"# receiver test log, line {i:03d}: firmware 1.2.3, antenna ANT-1, elevation mask 10 deg\r\n".encode()
    for s in range(n_sec):
        hms = f"1000{s:02d}.00"
        lat = f"4724.{2940 + 10 * s:04d}"
        rmc = sentence(f"GPRMC,{hms},A,{lat},N,01017.6700,E,10.0,90.0,150325,,,A")
        out += (rmc if s == 8 else rmc + "\r\n").encode()  # second 8: the line break before GGA lost
        gga = sentence(f"GPGGA,{hms},{lat},N,01017.6700,E,1,09,0.9,912.0,M,47.9,M,,")
        out += (f"2025-03-15T10:00:{s:02d}.000Z {gga}\r\n" if s == 5 else gga + "\r\n").encode()  # a logger prefix
        for k in range(40):
            out += (sentence(f"PUBX,00,{hms},{k},IMU,{0.01 * k:.2f}") + "\r\n").encode()
        out += (sentence("SDDBT,12.3,f,3.7,M,2.0,F") + "\r\n").encode()  # depth sounder
        out += (sentence("WIMWV,214.8,R,0.1,K,A") + "\r\n").encode()  # wind instrument
        out += b"!AIVDM,1,1,,A,13u?etPv2;0n:dDPwUM1U1Cb069D,0*24\r\n"  # AIS (checksum valid)
        if s % 7 == 3:
            out += b"\xb5\x62\x01\x07\x5c\x00\x00\xff\x13\x10\x80\xfe\x00"  # binary bytes, then a GGA on that line
    p = tmp_path / "test.log"
    p.write_bytes(bytes(out))
    return p


def test_quirky_log_is_sniffed_by_content_and_read(tmp_path):
    p = _quirky_log(tmp_path)
    assert read_recording(p).format == "nmea"  # sniffed, not by its first line or its name
    rec = nmea.read(p, Options())
    (s,) = rec.streams
    assert s.t.tolist() == [float(i) for i in range(20)]  # every second's fix, the prefixed one included
    assert col(rec, "lat")[5] == pytest.approx(47 + 24.2990 / 60, abs=1e-12)
    assert col(rec, "gnss_fix")[8] == 1 and col(rec, "gnss_sats")[8] == 9  # the GGA glued to its RMC
    assert col(rec, "gnss_speed") == pytest.approx([10.0 * KNOT] * 20)
    assert rec.meta["comment_lines"] == 120
    assert rec.meta["ignored_types"] == {"!AIVDM": 20, "PUBX": 800, "SD/DBT": 20, "WI/MWV": 20}
    assert rec.meta["ignored_sentences"] == 860
    assert not rec.warnings  # the binary bytes sat in front of a GGA on the same line: nothing lost


def test_binary_junk_lines_are_counted_not_fatal(tmp_path):
    p = _quirky_log(tmp_path)
    p.write_bytes(p.read_bytes() + b"\x00\x01\x02\xff\xfe garbage \x10\r\n" * 3)
    rec = nmea.read(p, Options())
    assert len(rec.streams[0].t) == 20
    (w,) = rec.warnings
    assert "skipped 3 of" in w and "3 binary" in w


def test_sniff_by_share_of_checksummed_sentences(tmp_path):
    gga = sentence("GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")
    csv = tmp_path / "a.csv"
    csv.write_text("time,lat,lon\n" + "".join(f"{i},47.0,10.0\n" for i in range(200)) + gga + "\n")
    assert not nmea.sniff(csv, csv.read_bytes()[:4096])  # one sentence among 200 CSV rows is not a log
    head = "# comment\n" * 3 + "\n".join([gga] * 4) + "\n"
    assert nmea.sniff(Path("x"), head.encode())
    assert not nmea.sniff(Path("x"), b"# only comments\n# here\n")
    # a log of sentences whose checksums all fail is still NMEA, so the reader can say so
    assert nmea.sniff(Path("x"), b"$GPGGA,1,2*00\n$GPRMC,3*11\n")


def _two_sessions_reversed(tmp_path: Path) -> Path:
    """Two 3-s sessions of one day, the later one first in the file (a logger that appends at the top)."""
    rows = []
    for start in (11, 10):
        for s in range(3):
            hms = f"{start}0000.00".replace("0000.00", f"00{s:02d}.00")
            rows += [
                f"GPRMC,{hms},A,4724.{2940 + start * 10 + s:04d},N,01017.6700,E,1.0,0.0,150325,,,A",
                f"GPGGA,{hms},4724.{2940 + start * 10 + s:04d},N,01017.6700,E,1,09,0.9,912.0,M,47.9,M,,",
            ]
    return write(tmp_path, rows, "two.nmea")


def test_two_sessions_in_reverse_order_are_sorted_and_reported(tmp_path):
    out = tmp_path / "two.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(_two_sessions_reversed(tmp_path)), "-o", str(out)], capture_output=True, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr.decode()
    info = proc.stderr.decode().strip().splitlines()[-1]
    assert "6 rows" in info and "1 backward steps" in info and "6 reordered" in info
    table, meta = sfio.read_table(out, kind="session")
    assert table.column("t").to_pylist() == [0.0, 1.0, 2.0, 3600.0, 3601.0, 3602.0]
    assert epoch_unix(meta) == calendar.timegm((2025, 3, 15, 10, 0, 0))
    lat = np.array(table.column("lat").to_pylist())
    assert np.all(np.diff(lat[:3]) > 0) and lat[3] > lat[2]  # each fix kept with its own values
    order = meta["provenance"][-1]["params"]["time_order"]
    assert order == {**order, "backward_steps": 1, "reordered": 6, "duplicates_dropped": 0, "samples": 6}


def test_gga_only_without_date_is_refused_by_ingest_naming_date(tmp_path):
    p = write(tmp_path, ["GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"] * 1
              + ["GPGGA,120001.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"])  # fmt: skip
    proc = subprocess.run([str(BIN / "ingest"), str(p)], capture_output=True, timeout=120)
    lines = proc.stderr.decode().strip().splitlines()
    assert proc.returncode == 1 and proc.stdout == b"" and len(lines) == 1
    assert lines[0].startswith("Error: ingest:") and "--date YYYY-MM-DD" in lines[0]
    out = tmp_path / "o.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(p), "--date", "2026-01-05", "-o", str(out)], capture_output=True)
    assert proc.returncode == 0, proc.stderr.decode()
    assert epoch_unix(sfio.read_table(out)[1]) == calendar.timegm((2026, 1, 5, 12, 0, 0))


def _ubx(rng: np.random.Generator, msg_class: int, msg_id: int, size: int) -> bytes:
    """One u-blox UBX binary message (sync 0xB5 0x62, class, id, little-endian length, payload, Fletcher checksum)."""
    body = (
        bytes([msg_class, msg_id]) + size.to_bytes(2, "little") + rng.integers(0, 256, size, dtype=np.uint8).tobytes()
    )
    a = b = 0
    for byte in body:
        a = (a + byte) & 0xFF
        b = (b + a) & 0xFF
    return b"\xb5\x62" + body + bytes([a, b])


def test_ubx_log_with_interleaved_nmea_is_sniffed_and_read(tmp_path):
    """A u-blox .ubx log: per second a NAV-PVT (92 B) and an RXM-RAWX (~1.3 kB) binary message, with the
    receiver's NMEA output (GGA + RMC) between them; the binary lines outnumber the sentences."""
    rng = np.random.default_rng(4)
    out = bytearray()
    for k in range(30):
        hh, mm, ss = 10, 0, k
        out += _ubx(rng, 0x01, 0x07, 92) + _ubx(rng, 0x02, 0x15, 16 + 32 * 40)
        lat = f"4730.{k:04d}"
        out += sentence(f"GNGGA,{hh:02d}{mm:02d}{ss:02d}.00,{lat},N,00930.0000,E,1,12,0.8,500.0,M,47.5,M,,").encode()
        out += b"\r\n"
        out += sentence(f"GNRMC,{hh:02d}{mm:02d}{ss:02d}.00,A,{lat},N,00930.0000,E,1.9,45.0,270126,,,A").encode()
        out += b"\r\n"
    p = tmp_path / "COM3_260127_100000.ubx"
    p.write_bytes(bytes(out))
    lines = [ln for ln in bytes(out).decode("ascii", "replace").splitlines() if ln.strip()]
    assert sum(1 for ln in lines if nmea.find_sentences(ln)) < 0.25 * len(lines)  # the old share rule failed
    assert nmea.sniff(p, bytes(out)[:4096])
    rec = read_recording(p)
    assert rec.format == "nmea"
    (st,) = rec.streams
    assert st.t.size == 30 and np.allclose(np.diff(st.t), 1.0)
    assert col(rec, "gnss_speed")[0] == pytest.approx(1.9 * 1852 / 3600)
    assert any("binary" in w for w in rec.warnings)


def test_csv_is_not_nmea_even_with_binary_lines(tmp_path):
    p = tmp_path / "x.csv"
    data = b"time,a,b\n" + b"".join(f"{i},{i * 2},{i * 3}\n".encode() for i in range(50)) + b"\x00\x01\x02\n" * 20
    p.write_bytes(data)
    assert not nmea.sniff(p, data[:4096])


def test_gga_log_whose_rmc_all_fail_their_checksum_names_them_and_date(tmp_path):
    lines = []
    for k in range(5):
        lines.append(sentence(f"GPGGA,1200{k:02d}.00,4730.0000,N,00930.0000,E,1,8,1.0,500.0,M,47.5,M,,"))
        good = sentence(f"GPRMC,1200{k:02d}.00,A,4730.0000,N,00930.0000,E,0.0,,270126,,,A")
        lines.append(good[:-2] + ("00" if good[-2:] != "00" else "11"))  # a wrong checksum
    p = tmp_path / "gga.nmea"
    p.write_text("\r\n".join(lines) + "\r\n")
    with pytest.raises(InputError) as err:
        read_recording(p)
    msg = str(err.value)
    assert "5 RMC sentence(s) failed their checksum" in msg and "--date" in msg
    rec = read_recording(p, opts=Options(date="2026-01-27"))
    assert rec.streams[0].t.size == 5


def test_hdop_unknown_marker_is_null(tmp_path):
    bodies = [
        "GPGGA,120000.00,4730.0000,N,00930.0000,E,1,8,99.99,500.0,M,47.5,M,,",
        "GPRMC,120000.00,A,4730.0000,N,00930.0000,E,0.0,,270126,,,A",
        "GPGGA,120001.00,4730.0000,N,00930.0000,E,1,8,1.2,500.0,M,47.5,M,,",
    ]
    rec = read_recording(write(tmp_path, bodies))
    h = col(rec, "gnss_hdop")
    assert h[0] is None and h[1] == 1.2
