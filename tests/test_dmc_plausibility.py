"""dmc-attitude warns about and flags an implausible magnetometer (issue 15, item 12).

Against the World Magnetic Model at the site: an inclination from ``--dip-from-data`` far from the
model's (a hard-iron offset the calibration missed), and a phone magnetometer disturbed for a while
(steel nearby: the field norm far from the model's intensity).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.magfield import inclination_declination, reference_field
from sportfusion.core.schema import floats, to_arrow
from sportfusion.skirace.attitude import magnetometer_plausibility
from sportfusion.skirace.dmc import dmc_table
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace


@pytest.fixture(scope="module")
def sim():
    return simulate_skirace(SkiRaceConfig(seed=1))


def with_mag(table, add):
    """The session with ``add(t, mag) -> mag`` applied to the magnetometer."""
    t = floats(table, "t")
    mag = np.column_stack([floats(table, f"mag_{a}") for a in "xyz"])
    new = add(t, mag)
    for i, a in enumerate("xyz"):
        table = table.set_column(table.column_names.index(f"mag_{a}"), f"mag_{a}", to_arrow(f"mag_{a}", new[:, i]))
    return table


def flags(res):
    return np.array([bool(v) for v in res.columns["mag_implausible"].to_pylist() if v is not None])


def test_clean_magnetometer_is_not_flagged(sim):
    for dip in (False, True):
        res = dmc_table(sim.session, sim.meta, dip_from_data=dip)
        assert not any("implausible" in w or "inclination" in w for w in res.warnings), res.warnings
        assert flags(res).sum() == 0
        assert abs(res.info["mag_norm_ratio"] - 1.0) < 0.05


def test_dip_from_data_far_from_the_model_warns_with_numbers(sim):
    bad = with_mag(sim.session, lambda t, m: m + np.array([0.0, 0.0, 20.0]))  # hard iron along body z [uT]
    res = dmc_table(bad, sim.meta, dip_from_data=True)
    lines = [w for w in res.warnings if "measured inclination" in w]
    assert len(lines) == 1
    site = sim.meta["frame"]["origin"]
    when = sfio_epoch(sim.meta) + float(np.median(floats(sim.session, "t")))
    inc_model = inclination_declination(reference_field(site[0], site[1], site[2], when))[0]
    assert f"{inc_model:.1f} deg" in lines[0] and f"{res.info['inclination_deg']:.1f} deg" in lines[0]
    assert res.info["inclination_deg"] - inc_model > 5.0
    f = flags(res)
    assert f.sum() > 0
    assert any("flagged in mag_implausible" in w for w in res.warnings)


def sfio_epoch(meta):
    from sportfusion.core.meta import epoch_unix

    return epoch_unix(meta)


def test_disturbed_span_is_flagged_there_only(sim):
    def steel(t, m):
        out = m.copy()
        span = (t > 20.0) & (t < 30.0)
        out[span] *= 1.4  # soft iron / a magnetised phone case: the norm 40 % above the model's
        return out

    bad = with_mag(sim.session, steel)
    res = dmc_table(bad, sim.meta)
    t = floats(bad, "t")
    rows = np.array([v is not None for v in res.columns["mag_implausible"].to_pylist()])
    f = flags(res)
    tr = t[rows]
    inside = (tr > 20.6) & (tr < 29.4)
    outside = (tr < 19.4) | (tr > 30.6)
    assert f[inside].mean() > 0.95
    assert f[outside].mean() < 0.01
    line = next(w for w in res.warnings if "magnetometer implausible" in w)
    assert "uT" in line and "model" in line


def test_plausibility_function_properties():
    rng = np.random.default_rng(0)
    m_ref = np.array([21.0, 1.0, 43.0])
    f_ref = np.array([0.0, 0.0, -9.81])
    n = 200
    # random attitudes: rotate both references by the same rotation -> always plausible
    from sportfusion.core.rotations import dcm_from_euler

    rot = dcm_from_euler(rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-3, 3, n))
    f_b = np.einsum("nij,j->ni", rot, f_ref)
    m_b = np.einsum("nij,j->ni", rot, m_ref)
    flag, err, ratio = magnetometer_plausibility(f_b, m_b, f_ref, m_ref, float(np.linalg.norm(m_ref)))
    assert not flag.any() and np.nanmax(np.abs(err)) < 1e-6 and np.allclose(ratio, 1.0)
    flag, err, _ = magnetometer_plausibility(f_b, m_b + np.array([0, 0, 25.0]), f_ref, m_ref, None)
    assert flag.mean() > 0.2  # direction off by more than 5 deg for many attitudes
    np.testing.assert_array_equal(flag, np.abs(err) > 5.0)  # norm steady (no model norm): the angle decides


def test_cli_warns_in_one_line_each(sim):
    bad = with_mag(sim.session, lambda t, m: m + np.array([0.0, 0.0, 20.0]))
    r = run_cli(["dmc-attitude", "--dip-from-data"], stdin=sfio.table_to_bytes(bad, sim.meta))
    assert r.returncode == 0, r.stderr.decode()
    err = r.stderr.decode()
    assert sum("measured inclination" in ln for ln in err.splitlines()) == 1
    out = sfio.table_from_bytes(r.stdout)
    assert out.schema.field("mag_implausible").type == "bool"
