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
