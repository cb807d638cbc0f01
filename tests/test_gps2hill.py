"""gps2hill command: numbers against pymap3d, metadata, pass-through, bad input."""

from __future__ import annotations

import io
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pymap3d
import pytest
from click.testing import CliRunner
from conftest import run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.frames import local_to_geodetic
from sportfusion.tools.gps2hill import main

ORIGIN = (47.4049, 10.2945, 948.0)  # lib/data/hills/oberstdorf_hs106.toml [site]
PSI = 312.6
N = 40


def _session() -> tuple[bytes, dict[str, np.ndarray]]:
    """GNSS on every other row, spread over 5 km around the take-off edge, with sigmas and NED velocity."""
    rng = np.random.default_rng(5)
    n, e, d = rng.uniform(-3500, 3500, N), rng.uniform(-3500, 3500, N), rng.uniform(-150, 150, N)
    lat, lon, h = (np.asarray(v) for v in pymap3d.ned2geodetic(n, e, d, *ORIGIN))
    mask = np.arange(N) % 2 == 1
    cols = {
        "lat": pa.array(lat, mask=mask),
        "lon": pa.array(lon, mask=mask),
        "h": pa.array(h, mask=mask),
        "vel_n": pa.array(rng.normal(size=N), mask=mask),
        "vel_e": pa.array(rng.normal(size=N), mask=mask),
        "vel_d": pa.array(rng.normal(size=N), mask=mask),
        "gnss_sigma_n": pa.array(np.full(N, 1.0), mask=mask),
        "gnss_sigma_e": pa.array(np.full(N, 3.0), mask=mask),
        "gnss_sigma_v": pa.array(np.full(N, 5.0), mask=mask),
        "acc_x": rng.normal(size=N),
    }
    return session_bytes(cols, n=N), {"lat": lat, "lon": lon, "h": h, "mask": mask}


def cli(args: list[str], stdin: bytes = b"") -> SimpleNamespace:
    """Run gps2hill in-process (click's CliRunner); the same fields as a subprocess result."""
    assert args[0] == "gps2hill"
    r = CliRunner().invoke(main, args[1:], input=stdin)
    return SimpleNamespace(returncode=r.exit_code, stdout=r.stdout_bytes, stderr=r.stderr_bytes)


def _read(data: bytes) -> tuple[pa.Table, dict]:
    return sfio.read_table(io.BytesIO(data))


def _eq31(n: np.ndarray, e: np.ndarray, psi: float) -> tuple[np.ndarray, np.ndarray]:
    c, s = np.cos(np.radians(psi)), np.sin(np.radians(psi))
    return c * n + s * e, -s * n + c * e


def test_help_and_version() -> None:
    r = run_cli(["gps2hill", "--help"])
    assert r.returncode == 0
    out = r.stdout.decode()
    assert "Example:" in out and "[deg]" in out and "[m]" in out and "--hill-set" in out
    assert run_cli(["gps2hill", "--version"]).returncode == 0


def test_hill_frame_against_pymap3d_and_round_trip() -> None:
    data, ref = _session()
    r = run_cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    table, meta = _read(r.stdout)
    x = table.column("gnss_x").to_numpy(zero_copy_only=False)
    y = table.column("gnss_y").to_numpy(zero_copy_only=False)
    z = table.column("gnss_z").to_numpy(zero_copy_only=False)
    ok = ~ref["mask"]
    assert table.column("gnss_x").null_count == ref["mask"].sum()
    n, e, d = pymap3d.geodetic2ned(ref["lat"][ok], ref["lon"][ok], ref["h"][ok], *ORIGIN)
    rx, ry = _eq31(np.asarray(n), np.asarray(e), PSI)
    assert np.abs(np.stack([x[ok] - rx, y[ok] - ry, z[ok] - d])).max() < 1e-3  # < 1 mm within 5 km
    lat, lon, h = local_to_geodetic(x[ok], y[ok], z[ok], ORIGIN, PSI)
    back = np.stack(pymap3d.geodetic2ned(lat, lon, h, *ORIGIN)) - np.stack([n, e, d])
    assert np.abs(back).max() < 1e-3  # round trip < 1 mm
    # sigmas: north 1 m, east 3 m rotated by 312.6 deg; vertical carried
    c, s = np.cos(np.radians(PSI)), np.sin(np.radians(PSI))
    sx = table.column("std_gnss_x").to_numpy(zero_copy_only=False)[ok]
    sy = table.column("std_gnss_y").to_numpy(zero_copy_only=False)[ok]
    np.testing.assert_allclose(sx, np.hypot(c * 1.0, s * 3.0))
    np.testing.assert_allclose(sy, np.hypot(s * 1.0, c * 3.0))
    np.testing.assert_allclose(table.column("std_gnss_z").to_numpy(zero_copy_only=False)[ok], 5.0)
    # pass-through: NED velocity and every other column untouched
    src = pq.read_table(io.BytesIO(data))
    for name in src.column_names:
        assert table.column(name).equals(src.column(name)), name
    assert meta["frame"] == {
        "name": "hill",
        "origin": list(ORIGIN),
        "azimuth_deg": PSI,
        "axes": "x forward, y right, z down",
        "height_ref": "ellipsoidal",  # issue 15: the heights the frame and gnss_z rest on
        "gnss_z_ref": "ellipsoidal",
    }
    assert table.schema.field("gnss_z").metadata[b"height_ref"] == b"ellipsoidal"
    assert meta["hill"]["name"] == "Oberstdorf HS106" and meta["hill"]["certificate"]["w"] == 95.0
    assert meta["provenance"][-1]["tool"] == "gps2hill"
    assert meta["provenance"][-1]["params"]["hill"] == "oberstdorf_hs106"


def test_origin_and_azimuth_for_any_venue() -> None:
    data, ref = _session()
    origin = "47.41,10.3,900"
    r = cli(["gps2hill", "--origin", origin, "-q"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    table, meta = _read(r.stdout)
    ok = ~ref["mask"]
    n, e, d = pymap3d.geodetic2ned(ref["lat"][ok], ref["lon"][ok], ref["h"][ok], 47.41, 10.3, 900.0)
    x = table.column("gnss_x").to_numpy(zero_copy_only=False)[ok]
    assert np.abs(x - n).max() < 1e-3  # azimuth 0: x = north
    assert meta["frame"]["name"] == "local" and meta["frame"]["azimuth_deg"] == 0.0 and "hill" not in meta
    r2 = cli(["gps2hill", "--origin", origin, "--azimuth", "90", "-q"], stdin=data)
    t2, m2 = _read(r2.stdout)
    assert np.abs(t2.column("gnss_x").to_numpy(zero_copy_only=False)[ok] - e).max() < 1e-3
    assert m2["frame"]["azimuth_deg"] == 90.0


def test_paper_method_differs_by_the_measured_amount() -> None:
    data, ref = _session()
    exact = _read(cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=data).stdout)[0]
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106", "--method", "paper", "-q"], stdin=data)
    assert r.returncode == 0
    paper, meta = _read(r.stdout)
    diff = np.stack(
        [
            paper.column(c).to_numpy(zero_copy_only=False) - exact.column(c).to_numpy(zero_copy_only=False)
            for c in ("gnss_x", "gnss_y", "gnss_z")
        ]
    )[:, ~ref["mask"]]
    ok = ~ref["mask"]
    dist = np.hypot(*(exact.column(c).to_numpy(zero_copy_only=False)[ok] for c in ("gnss_x", "gnss_y")))
    err = np.linalg.norm(diff, axis=0)
    # quadratic in the distance: about 0.13 m per km^2 (see lib/core/frames.py)
    assert np.all(err < 0.15 * (dist / 1000) ** 2 + 1e-3)
    assert err.max() > 0.05
    assert meta["provenance"][-1]["params"]["method"] == "paper"


def test_hill_set_changes_the_origin(tmp_path: Path) -> None:
    data, _ = _session()
    base = _read(cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=data).stdout)[0]
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106", "--hill-set", "height=958", "-q"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    t, m = _read(r.stdout)
    dz = t.column("gnss_z").to_numpy(zero_copy_only=False) - base.column("gnss_z").to_numpy(zero_copy_only=False)
    assert np.nanmax(np.abs(dz - 10.0)) < 0.01  # origin 10 m higher: everything 10 m further down
    assert m["frame"]["origin"][2] == 958.0 and m["hill"]["overrides"] == {"height": "958"}


def _one_error_line(r, tool: str = "gps2hill") -> str:  # type: ignore[no-untyped-def]
    assert r.returncode == 1, r.stderr.decode()
    assert r.stdout == b""
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {tool}: "), lines
    return lines[0]


def test_bad_input(tmp_path: Path) -> None:
    no_gnss = session_bytes({"acc_x": np.zeros(20)})
    line = _one_error_line(cli(["gps2hill", "--hill", "oberstdorf_hs106"], stdin=no_gnss))
    assert "lat" in line and "h" in line
    data, _ = _session()
    line = _one_error_line(cli(["gps2hill", "--hill", "schattenberg_hs999"], stdin=data))
    assert "unknown hill" in line and "oberstdorf_hs106" in line
    bad = tmp_path / "bad.toml"
    bad.write_text("[certificate\nw = = 95\n")
    line = _one_error_line(cli(["gps2hill", "--hill", str(bad)], stdin=data))
    assert "not valid TOML" in line
    line = _one_error_line(cli(["gps2hill", "--hill", "planica_hs138"], stdin=data))
    assert "--origin" in line
    line = _one_error_line(cli(["gps2hill", "--hill", "oberstdorf_hs106", "--hill-set", "betaP=20"], stdin=data))
    assert "beyond K" in line
    _one_error_line(cli(["gps2hill", "--origin", "47,10,900"], stdin=b""))
    _one_error_line(cli(["gps2hill", "--origin", "47,10,900"], stdin=b"not parquet at all"))


def test_usage_errors() -> None:
    data, _ = _session()
    for args in (
        ["gps2hill"],
        ["gps2hill", "--hill-set", "e=90", "--origin", "47,10,0"],
        ["gps2hill", "--origin", "47,10"],
    ):
        r = run_cli(args, stdin=data)
        assert r.returncode == 2 and r.stdout == b"", args


def test_metadata_carried_forward() -> None:
    meta = sfmeta.new_meta("session", 1.7e9)
    meta["events"] = [{"name": "takeoff", "t": 1.0}]
    data = session_bytes({"lat": [47.4] * 20, "lon": [10.29] * 20, "h": [900.0] * 20}, meta=meta)
    r = cli(["gps2hill", "--origin", "47.4,10.29,900", "-q"], stdin=data)
    _, m = _read(r.stdout)
    assert m["events"] == meta["events"] and m["time"] == meta["time"]
    assert [p["tool"] for p in m["provenance"]] == ["gps2hill"]


@pytest.mark.parametrize("hill", ["hakuba_hs131", "rasnov_hs38"])
def test_community_hills_with_an_origin(hill: str) -> None:
    data, _ = _session()
    r = cli(["gps2hill", "--hill", hill, "--origin", "47.4,10.29,900", "--azimuth", "10", "-q"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    _, m = _read(r.stdout)
    assert m["frame"]["name"] == "hill" and m["hill"]["source"] == "community data (Open-Ski-Jumping, MIT)"


# --- tracks without an ellipsoidal height (issue 15, item 2) ---------------------------------------------

GEOID_N = 47.9  # geoid separation used to write the MSL tracks below [m]


def _track(heights: str, n: int = 30) -> tuple[bytes, dict[str, np.ndarray]]:
    """A 1.5 km track near the HS106 take-off edge: heights 'ellipsoidal', 'msl', 'mixed' or 'none'."""
    k = np.arange(n, dtype=float)
    ned_n, ned_e, ned_d = 40.0 * k, 25.0 * k - 300.0, 3.0 * k - 60.0
    lat, lon, h = (np.asarray(v) for v in pymap3d.ned2geodetic(ned_n, ned_e, ned_d, *ORIGIN))
    cols: dict[str, object] = {"lat": lat, "lon": lon, "gnss_sigma_v": np.full(n, 2.0)}
    if heights == "ellipsoidal":
        cols["h"] = h
    elif heights == "msl":
        cols["h_msl"] = h - GEOID_N
    elif heights == "mixed":  # NMEA fixes with and without the GGA separation field
        cols["h"] = pa.array(h, mask=k % 3 == 0)
        cols["h_msl"] = h - GEOID_N
    return session_bytes(cols, n=n), {"lat": lat, "lon": lon, "h": h}


def test_msl_only_track_refused_for_a_hill_frame_naming_the_fix() -> None:
    data, _ = _track("msl")
    line = _one_error_line(cli(["gps2hill", "--hill", "oberstdorf_hs106"], stdin=data))
    assert "mean sea level" in line and "--geoid-offset" in line
    line = _one_error_line(cli(["gps2hill", "--origin", "47.4,10.29,900"], stdin=data))
    assert "--geoid-offset" in line and "--origin auto" in line


def test_msl_track_with_geoid_offset_equals_the_ellipsoidal_track() -> None:
    ref = cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=_track("ellipsoidal")[0])
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106", "--geoid-offset", str(GEOID_N)], stdin=_track("msl")[0])
    assert r.returncode == 0, r.stderr.decode()
    assert f"h = h_msl + {GEOID_N:.2f} m from --geoid-offset" in r.stderr.decode()
    (a, _), (b, m) = _read(ref.stdout), _read(r.stdout)
    for c in ("gnss_x", "gnss_y", "gnss_z", "std_gnss_z"):
        np.testing.assert_allclose(b.column(c).to_numpy(), a.column(c).to_numpy(), atol=1e-6, err_msg=c)
    assert m["frame"]["geoid_offset_m"] == GEOID_N and m["frame"]["geoid_source"] == "--geoid-offset"
    assert m["provenance"][-1]["params"]["geoid_offset"] == GEOID_N
    assert b.schema.field("h_msl").metadata[b"height_ref"] == b"msl"


def test_receiver_separation_fills_fixes_without_it() -> None:
    data, truth = _track("mixed")
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    assert "from receiver" in r.stderr.decode()
    table, m = _read(r.stdout)
    assert table.column("gnss_x").null_count == 0  # every fix placed, also those with h_msl only
    n_, e_, d_ = pymap3d.geodetic2ned(truth["lat"], truth["lon"], truth["h"], *ORIGIN)
    np.testing.assert_allclose(table.column("gnss_z").to_numpy(), d_, atol=1e-6)
    assert m["frame"]["geoid_offset_m"] == pytest.approx(GEOID_N, abs=1e-9)


def test_origin_auto_on_an_msl_track_keeps_msl_heights_and_says_so() -> None:
    data, truth = _track("msl")
    r = cli(["gps2hill", "--origin", "auto", "--azimuth", "30"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    assert "heights above mean sea level" in r.stderr.decode()
    table, m = _read(r.stdout)
    h0 = truth["h"][0] - GEOID_N
    assert m["frame"]["origin"] == pytest.approx([truth["lat"][0], truth["lon"][0], h0], abs=1e-12)
    assert m["frame"]["height_ref"] == "msl" and m["frame"]["gnss_z_ref"] == "msl"
    assert m["frame"]["name"] == "local"
    # independent reference: pymap3d's NED about the first fix, on the MSL heights, rotated by eq 31
    n_, e_, d_ = pymap3d.geodetic2ned(
        truth["lat"], truth["lon"], truth["h"] - GEOID_N, truth["lat"][0], truth["lon"][0], h0
    )
    x, y = _eq31(np.asarray(n_), np.asarray(e_), 30.0)
    np.testing.assert_allclose(table.column("gnss_x").to_numpy(), x, atol=1e-6)
    np.testing.assert_allclose(table.column("gnss_y").to_numpy(), y, atol=1e-6)
    np.testing.assert_allclose(table.column("gnss_z").to_numpy(), d_, atol=1e-6)
    assert table.column("gnss_x").to_numpy()[0] == pytest.approx(0.0, abs=1e-9)
    assert table.schema.field("gnss_z").metadata[b"height_ref"] == b"msl"


def test_two_d_track_gets_x_y_and_a_null_z() -> None:
    data, truth = _track("none")
    r = cli(["gps2hill", "--origin", "auto"], stdin=data)
    assert r.returncode == 0, r.stderr.decode()
    assert "2-D" in r.stderr.decode()
    table, m = _read(r.stdout)
    assert table.column("gnss_z").null_count == table.num_rows and "std_gnss_z" not in table.column_names
    assert m["frame"]["height_ref"] == "none" and m["frame"]["origin"][2] == 0.0
    assert table.schema.field("gnss_z").metadata[b"height_ref"] == b"none"
    # x/y at height 0: pymap3d at 0 m, and within h/R = 0.015 % of the true horizontal distances at ~950 m
    n0, e0, _ = pymap3d.geodetic2ned(truth["lat"], truth["lon"], 0.0, truth["lat"][0], truth["lon"][0], 0.0)
    np.testing.assert_allclose(table.column("gnss_x").to_numpy(), n0, atol=1e-6)
    np.testing.assert_allclose(table.column("gnss_y").to_numpy(), e0, atol=1e-6)
    n1, e1, _ = pymap3d.geodetic2ned(
        truth["lat"], truth["lon"], truth["h"], truth["lat"][0], truth["lon"][0], truth["h"][0]
    )
    assert np.hypot(n0[-1], e0[-1]) == pytest.approx(np.hypot(n1[-1], e1[-1]), rel=2e-4)
    # with a hill: the fixes are placed at the take-off edge's height, z still null
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=data)
    table, m = _read(r.stdout)
    assert m["frame"]["height_ref"] == "ellipsoidal" and m["frame"]["gnss_z_ref"] == "none"
    assert table.column("gnss_z").null_count == table.num_rows and table.column("gnss_x").null_count == 0


def test_geoid_offset_must_be_a_plausible_separation() -> None:
    data, _ = _track("msl")
    for bad in ("nan", "inf", "1e300"):
        r = cli(["gps2hill", "--origin", "auto", "--geoid-offset", bad], stdin=data)
        assert r.returncode == 2 and r.stdout == b"", bad


def test_rows_left_without_a_height_are_counted_not_silent() -> None:
    # two inputs merged: one with ellipsoidal h, one with MSL heights only and no separation anywhere
    data, truth = _track("ellipsoidal", n=10)
    table, meta = _read(data)
    h = np.array(table.column("h").to_pylist(), dtype=float)
    h_msl = np.where(np.arange(10) >= 6, h - GEOID_N, np.nan)
    h[6:] = np.nan
    mixed = session_bytes(
        {
            "lat": truth["lat"],
            "lon": truth["lon"],
            "h": pa.array(h, mask=np.isnan(h)),
            "h_msl": pa.array(h_msl, mask=np.isnan(h_msl)),
        },
        n=10,
    )
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106"], stdin=mixed)
    assert r.returncode == 0, r.stderr.decode()
    assert "4 row(s) with lat/lon have no usable height" in r.stderr.decode()
    assert _read(r.stdout)[0].column("gnss_x").null_count == 4
    r = cli(["gps2hill", "--hill", "oberstdorf_hs106", "--geoid-offset", str(GEOID_N), "-q"], stdin=mixed)
    out = _read(r.stdout)[0]
    n_, e_, d_ = pymap3d.geodetic2ned(truth["lat"], truth["lon"], truth["h"], *ORIGIN)
    np.testing.assert_allclose(out.column("gnss_z").to_numpy(), d_, atol=1e-6)
