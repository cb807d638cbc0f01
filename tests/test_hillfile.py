"""Hill files: shipped names, user files, --hill-set overrides, metadata, bad files."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from sportfusion.core.errors import InputError
from sportfusion.core.gravity import normal_gravity
from sportfusion.skijump.hillfile import load_hill, shipped_hills

ROOT = Path(__file__).resolve().parents[1]
HILL_DIR = ROOT / "lib" / "data" / "hills"
COMMUNITY = "community data (Open-Ski-Jumping, MIT)"


def test_shipped_names_and_spellings() -> None:
    names = shipped_hills()
    assert len(names) >= 9 and "oberstdorf_hs106" in names
    for spelling in ("oberstdorf_hs106", "Oberstdorf HS106", "OBERSTDORF-HS106"):
        assert load_hill(spelling).name == "Oberstdorf HS106"


def test_every_shipped_hill_is_labelled_and_builds() -> None:
    for name in shipped_hills():
        hill = load_hill(name)
        assert hill.source == COMMUNITY, name
        assert hill.profile.cert.w > 0


def test_oberstdorf_site_from_the_paper() -> None:
    hill = load_hill("oberstdorf_hs106")
    frame = hill.frame()
    assert frame.azimuth_deg == 312.6 and frame.name == "hill"
    assert hill.gravity() == 9.8053
    assert frame.lat == pytest.approx(47.405, abs=0.002) and frame.lon == pytest.approx(10.294, abs=0.003)
    assert hill.mag_field() == pytest.approx((21.4606, 1.4779, 43.44))


def test_load_by_path_and_overrides(tmp_path: Path) -> None:
    f = tmp_path / "mine.toml"
    f.write_text((HILL_DIR / "oberstdorf_hs106.toml").read_text())
    base = load_hill(str(f))
    hill = load_hill(
        str(f), {"e": "95.5", "height": "951.25", "site.g0": "9.81", "certificate.gates": "30", "name": "Mine"}
    )
    assert hill.name == "Mine" and hill.spec == str(f)
    assert hill.profile.cert.e == 95.5 and hill.profile.cert.gates == 30
    assert hill.site["height"] == 951.25 and hill.gravity() == 9.81
    # a longer in-run moves A up the straight by exactly the extra length
    d = hill.profile.points["A"] - base.profile.points["A"]
    assert float((d**2).sum() ** 0.5) == pytest.approx(6.5, abs=1e-9)
    assert hill.meta()["overrides"]["e"] == "95.5"


def test_type_override_and_normal_gravity_fallback(tmp_path: Path) -> None:
    hill = load_hill("oberstdorf_hs106", {"type": "ICR1996"})
    assert hill.profile.cert.type == "ICR1996"
    f = tmp_path / "nog.toml"
    text = (HILL_DIR / "oberstdorf_hs106.toml").read_text().replace("g0 = 9.8053\n", "")
    f.write_text(text)
    h = load_hill(str(f))
    assert h.gravity() == pytest.approx(normal_gravity(47.4049, 948.0), abs=1e-12)


def test_meta_is_json() -> None:
    meta = load_hill("hakuba_hs131").meta()
    text = json.dumps(meta, allow_nan=False)
    back = json.loads(text)
    assert back["certificate"]["type"] == "ICR1992" and "betaL" not in back["certificate"]
    assert set(back["points"]) >= {"A", "B", "E1", "E2", "T", "F", "P", "K", "L", "U"}
    assert back["source"] == COMMUNITY


def test_community_hill_without_site_needs_an_origin() -> None:
    hill = load_hill("planica_hs138")
    assert not hill.has_origin
    with pytest.raises(InputError, match="--origin"):
        hill.frame()
    assert load_hill("planica_hs138", {"lat": "46.48", "lon": "13.72", "height": "990", "azimuth_deg": "90"}).has_origin


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"colour": "red"}, "unknown key"),
        ({"e": "long"}, "expected a number"),
        ({"gates": "2.5"}, "whole number"),
        ({"weather.wind": "3"}, "unknown section"),
        ({"site.w": "3"}, "unknown site value"),
        ({"betaP": "30"}, "beyond K"),
        ({"type": "ICR1970"}, "'type'"),
        ({"g0": "12"}, "g0"),
    ],
)
def test_bad_overrides(overrides: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        load_hill("oberstdorf_hs106", overrides)


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"unknown hill 'nowhere_hs1'; shipped hills: .*oberstdorf_hs106"):
        load_hill("nowhere_hs1")
    with pytest.raises(InputError, match="does not exist"):
        load_hill(str(tmp_path / "missing.toml"))
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[certificate\nw = 95\n')
    with pytest.raises(InputError, match="not valid TOML"):
        load_hill(str(bad))
    nocert = tmp_path / "nocert.toml"
    nocert.write_text('name = "x"\n')
    with pytest.raises(InputError, match=r"no \[certificate\]"):
        load_hill(str(nocert))
    short = tmp_path / "short.toml"
    short.write_text('[certificate]\ntype = "ICR2008"\nw = 95.0\n')
    with pytest.raises(InputError, match="missing"):
        load_hill(str(short))
    site = tmp_path / "site.toml"
    site.write_text((HILL_DIR / "oberstdorf_hs106.toml").read_text().replace("[site]", "[site]\naltitude = 3"))
    with pytest.raises(InputError, match="unknown \\[site\\] key"):
        load_hill(str(site))


SHARED = Path("/work/shared/data/hills")
if not SHARED.is_dir():
    SHARED = ROOT.parent / "shared" / "data" / "hills"


@pytest.mark.skipif(not SHARED.is_dir(), reason="community JSON (shared/data/hills) not available")
def test_shipped_files_reproduce_from_the_converter() -> None:
    spec = importlib.util.spec_from_file_location("convert_hills", ROOT / "fixtures" / "convert_hills.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    shipped = set(shipped_hills())
    for json_name, profile_name in mod.SELECTION:
        text, _ = mod.convert(SHARED, json_name, profile_name)
        name = mod.file_name(profile_name)
        assert name in shipped
        assert (HILL_DIR / f"{name}.toml").read_text() == text, name
    assert len(mod.SELECTION) == len(shipped)


def test_shipped_hills_found_without_the_folder_beside_the_package(monkeypatch: pytest.MonkeyPatch) -> None:
    """The hills are read from the folder beside the package; where there is none (another loader), through
    importlib.resources: the same names either way."""
    from sportfusion.skijump import hillfile

    names = shipped_hills()
    monkeypatch.setattr(hillfile, "__file__", "/nonexistent/sportfusion/skijump/hillfile.py")
    assert shipped_hills() == names
    assert load_hill(names[0]).name
