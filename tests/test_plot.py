"""plot hill / plot track: valid, non-trivial PNG and SVG files; bad input."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from click.testing import CliRunner
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.frames import gnss_to_frame
from sportfusion.skijump.hillfile import load_hill
from sportfusion.tools.plot import main

pytest.importorskip("matplotlib")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def invoke(args: list[str], stdin: bytes = b"") -> tuple[int, str]:
    r = CliRunner().invoke(main, args, input=stdin)
    return r.exit_code, r.stderr


def check_png(path: Path) -> None:
    from matplotlib.image import imread

    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC and len(data) > 20_000
    img = imread(io.BytesIO(data), format="png")
    assert img.shape[0] > 400 and img.shape[1] > 600
    rgba = (img * 255).round().astype(np.uint8)
    colours = np.unique(rgba.reshape(-1, rgba.shape[-1]).view(np.uint32))
    assert len(colours) > 20  # not a blank or single-colour image
    # ink covers a real share of the picture, but not all of it
    ink = (img[..., :3].mean(axis=-1) < 0.95).mean()
    assert 0.01 < ink < 0.8


def check_svg(path: Path) -> None:
    text = path.read_text()
    assert text.lstrip().startswith("<?xml") and "<svg" in text and text.rstrip().endswith("</svg>")
    assert len(text) > 20_000 and text.count("<path") > 20


def session_bytes_on_hill() -> bytes:
    """A session in the Oberstdorf hill frame with GNSS, an estimate and its sigmas."""
    hill = load_hill("oberstdorf_hs106")
    frame, p = hill.frame(), hill.profile
    t = np.arange(0.0, 10.0, 0.01)
    x = np.interp(t, [0, 5, 10], [-80, 0, 200])
    z = np.where(x <= 0, p.z_inrun(np.minimum(x, 0)), p.z_landing(np.maximum(x, 0), extend=True))
    y = 0.4 * np.sin(t)
    lat, lon, h = frame.to_geodetic(x, y, z + np.random.default_rng(2).normal(0, 1.0, t.size))
    mask = np.arange(t.size) % 10 != 0
    table = pa.table(
        {
            "t": t,
            "lat": pa.array(lat, mask=mask),
            "lon": pa.array(lon, mask=mask),
            "h": pa.array(h, mask=mask),
            "x": x,
            "y": y,
            "z": z,
            "std_y": np.full(t.size, 0.2),
            "std_z": np.full(t.size, 0.5),
        }
    )
    table, meta = gnss_to_frame(table, sfmeta.new_meta("session", 1.7e9), frame, hill_meta=hill.meta())
    return sfio.table_to_bytes(table, meta)


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_plot_hill(tmp_path: Path, suffix: str) -> None:
    out = tmp_path / f"hill{suffix}"
    code, err = invoke(["hill", "--hill", "oberstdorf_hs106", "-o", str(out)])
    assert code == 0, err
    (check_png if suffix == ".png" else check_svg)(out)


def test_plot_hill_other_generations_and_overrides(tmp_path: Path) -> None:
    for name in ("hakuba_hs131", "harrachov_hs210"):
        out = tmp_path / f"{name}.png"
        code, err = invoke(["hill", "--hill", name, "--hill-set", "a=60", "--dpi", "80", "-o", str(out), "-q"])
        assert code == 0, err
        assert out.read_bytes()[:8] == PNG_MAGIC and len(out.read_bytes()) > 10_000


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_plot_track(tmp_path: Path, suffix: str) -> None:
    src = tmp_path / "s.parquet"
    src.write_bytes(session_bytes_on_hill())
    out = tmp_path / f"track{suffix}"
    code, err = invoke(["track", str(src), "-o", str(out)])
    assert code == 0, err
    (check_png if suffix == ".png" else check_svg)(out)


def test_plot_track_from_stdin_with_hill_option(tmp_path: Path) -> None:
    out = tmp_path / "t.png"
    code, err = invoke(["track", "--hill", "oberstdorf_hs106", "-o", str(out), "-q"], stdin=session_bytes_on_hill())
    assert code == 0, err
    check_png(out)


def test_help_and_console_script() -> None:
    r = run_cli(["plot", "--help"])
    assert r.returncode == 0 and b"hill" in r.stdout and b"track" in r.stdout
    for sub in ("hill", "track"):
        r = CliRunner().invoke(main, [sub, "--help"])
        assert r.exit_code == 0 and "Example:" in r.stdout and ".png, .svg or .pdf" in " ".join(r.stdout.split())
    assert CliRunner().invoke(main, ["--version"]).exit_code == 0


def test_bad_input(tmp_path: Path) -> None:
    out = tmp_path / "x.png"
    code, err = invoke(["hill", "--hill", "nowhere", "-o", str(out)])
    assert code == 1 and err.strip().startswith("Error: plot hill: unknown hill") and len(err.strip().splitlines()) == 1
    assert not out.exists()
    code, _ = invoke(["hill", "--hill", "oberstdorf_hs106", "-o", str(tmp_path / "x.jpg")])
    assert code == 2
    code, _ = invoke(["hill", "-o", str(out)])
    assert code == 2
    bare = sfio.table_to_bytes(pa.table({"t": [0.0, 1.0], "acc_x": [0.0, 1.0]}), sfmeta.new_meta("session"))
    code, err = invoke(["track", "-o", str(out)], stdin=bare)
    assert code == 1 and "gps2hill" in err and len(err.strip().splitlines()) == 1
    code, err = invoke(["track", "-o", str(out)], stdin=b"")
    assert code == 1 and err.startswith("Error: plot track:")
    assert not out.exists()
