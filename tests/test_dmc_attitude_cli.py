"""``dmc-attitude`` end to end on simulated ski runs: accuracy vs truth, options, error lines."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.magfield import inclination_declination, reference_field
from sportfusion.core.rotations import quat_angle
from sportfusion.core.schema import floats
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace


def cli(args: list[str], data: bytes) -> tuple[pa.Table, str]:
    res = run_cli(args, stdin=data)
    assert res.returncode == 0, res.stderr.decode()
    return sfio.table_from_bytes(res.stdout), res.stderr.decode()


def quats(table, prefix=""):
    return np.column_stack([floats(table, f"{prefix}q{i}") for i in range(4)])


@pytest.fixture(scope="module")
def sim():
    s = simulate_skirace(SkiRaceConfig(seed=1))
    return s, sfio.table_to_bytes(s.session, s.meta)


@pytest.fixture(scope="module")
def low(sim):
    """dmc-attitude straight on the session: no GNSS acceleration, low-dynamics assumption."""
    return cli(["dmc-attitude"], sim[1])


def errors_deg(out, truth):
    q = quats(out)
    rows = np.isfinite(q[:, 0])
    return rows, np.degrees(quat_angle(q[rows], quats(truth, "true_")[rows]))


def test_low_dynamics_within_one_degree(sim, low):
    s, _ = sim
    out, err = low
    assert "assuming low dynamics" in err and "Error" not in err
    rows, e = errors_deg(out, s.truth)
    static = floats(out, "t")[rows] < 5.0
    print(f"low dynamics (standing start): median attitude error {np.median(e[static]):.2f} deg")
    assert np.median(e[static]) < 1.0
    assert rows.sum() == np.isfinite(floats(out, "acc_x")).sum()  # every accelerometer row, no other
    meta = sfio.get_meta(out)
    assert meta["provenance"][-1]["tool"] == "dmc-attitude"
    assert out.schema.field("yaw").metadata[b"unit"] == b"rad"


def test_high_dynamics_with_gnss_acceleration(sim):
    s, data = sim
    smooth = run_cli(["spline-smooth"], stdin=data)
    assert smooth.returncode == 0, smooth.stderr
    out, _ = cli(["dmc-attitude"], smooth.stdout)
    rows, e = errors_deg(out, s.truth)
    t = floats(out, "t")[rows]
    sing = out.column("dmc_singular").to_numpy(zero_copy_only=False)[rows].astype(bool)
    run = (t > 6.0) & ~sing
    med, p90 = np.median(e[run]), np.percentile(e[run], 90)
    a_dmc = np.column_stack([floats(out, f"a{c}_dmc") for c in "xyz"])[rows]
    a_true = np.column_stack([floats(s.truth, f"true_a{c}") for c in "xyz"])[rows]
    a_err = np.median(np.linalg.norm(a_dmc - a_true, axis=1)[run])
    print(
        f"high dynamics (run, GNSS acceleration from spline-smooth): median attitude error {med:.2f} deg, "
        f"90th percentile {p90:.2f} deg; kinematic acceleration re-estimated from f^b: median error {a_err:.2f} m/s^2"
    )
    assert med < 5.0 and a_err < 1.0
    # without the GNSS acceleration the run's attitude is far worse (the reason for eq 9)
    low_out, _ = cli(["dmc-attitude"], data)
    _, e_low = errors_deg(low_out, s.truth)
    assert np.median(e_low[run]) > 5 * med
    # free fall over the jumps is flagged, and little else
    flight = np.zeros(rows.sum(), bool)
    for t0, t1 in s.fine["flights"]:
        flight |= (t > t0 + 0.15) & (t < t1 - 0.15)  # the 5 Hz low-pass smears the edges
    print(f"free fall flagged on {sing[flight].mean():.0%} of in-flight rows, {sing[~flight].mean():.1%} of the others")
    assert sing[flight].mean() > 0.8
    assert sing[~flight].mean() < 0.02
    loss = floats(out, "quest_loss")[rows]
    assert np.median(loss[flight]) > np.median(loss[~flight])


def test_normalised_magnetometer_and_given_reference(sim):
    s, data = sim
    base, _ = cli(["dmc-attitude", "--lowpass", "0"], data)
    table = s.session
    m = np.column_stack([floats(table, f"mag_{a}") for a in "xyz"])
    unit = m / np.linalg.norm(m, axis=1, keepdims=True)
    for i, a in enumerate("xyz"):
        table = table.set_column(
            table.column_names.index(f"mag_{a}"), f"mag_{a}", pa.array(unit[:, i], mask=np.isnan(unit[:, i]))
        )
    meta = dict(s.meta, units={"mag_x": "1", "mag_y": "1", "mag_z": "1"})
    out, _ = cli(["dmc-attitude", "--lowpass", "0"], sfio.table_to_bytes(table, meta))
    assert out.schema.field("mag_x").metadata[b"unit"] == b"1"
    ok = np.isfinite(floats(out, "q0"))
    assert np.max(quat_angle(quats(out)[ok], quats(base)[ok])) < 1e-9
    f = reference_field(46.4975, 9.8365, 2200.0, s.meta["time"]["epoch_utc"])
    given, _ = cli(["dmc-attitude", "--lowpass", "0", "--mag-ref", ",".join(f"{v:.6f}" for v in f)], data)
    assert np.degrees(np.max(quat_angle(quats(given)[ok], quats(base)[ok]))) < 0.05


def test_dip_from_data(sim):
    s, data = sim
    out, err = cli(["dmc-attitude", "--dip-from-data"], data)
    inc_wmm = inclination_declination(reference_field(46.4975, 9.8365, 2200.0, "2026-02-10"))[0]
    line = [ln for ln in err.splitlines() if "inclination" in ln][0]
    inc = float(line.split("inclination ")[1].split(" deg")[0])
    print(f"dip from quiet samples {inc:.2f} deg, WMM {inc_wmm:.2f} deg")
    assert abs(inc - inc_wmm) < 1.0
    rows, e = errors_deg(out, s.truth)
    assert np.median(e[floats(out, "t")[rows] < 5.0]) < 1.5


def test_site_is_required_for_the_model(sim):
    s, _ = sim
    table = s.session.drop_columns(["lat", "lon", "h"])
    meta = {k: v for k, v in s.meta.items() if k != "frame"}
    data = sfio.table_to_bytes(table, meta)
    res = run_cli(["dmc-attitude"], stdin=data)
    assert res.returncode == 1 and res.stdout == b""
    line = [ln for ln in res.stderr.decode().splitlines() if ln.startswith("Error:")][0]
    assert line.startswith("Error: dmc-attitude: ") and "--site" in line
    ok = run_cli(["dmc-attitude", "--site", "46.4975,9.8365,2200"], stdin=data)
    assert ok.returncode == 0, ok.stderr
    assert run_cli(["dmc-attitude", "--site", "46.4"], stdin=data).returncode == 2


def test_magnetometer_on_other_rows_is_interpolated(sim):
    from sportfusion.skirace.dmc import dmc_session

    s, _ = sim
    t = floats(s.session, "t")
    acc = np.column_stack([floats(s.session, f"acc_{a}") for a in "xyz"])
    mag = np.column_stack([floats(s.session, f"mag_{a}") for a in "xyz"])
    kw = dict(azimuth_deg=160.0, site=(46.4975, 9.8365, 2200.0), when="2026-02-10T10:00:00Z", lowpass_hz=0.0)
    same = dmc_session(t, acc, mag, **kw)
    # move every other magnetometer sample onto a row of its own (a multi-rate session)
    rows = np.flatnonzero(np.isfinite(mag[:, 0]))[1::2]
    t2 = np.sort(np.concatenate((t, t[rows] + 0.004)))
    pos = np.searchsorted(t2, t)
    acc2 = np.full((t2.size, 3), np.nan)
    mag2 = np.full((t2.size, 3), np.nan)
    acc2[pos] = acc
    mag2[pos] = mag
    mag2[pos[rows]] = np.nan
    mag2[np.searchsorted(t2, t[rows] + 0.004)] = mag[rows]
    moved = dmc_session(t2, acc2, mag2, **kw)
    q1 = np.column_stack([same.columns[f"q{i}"] for i in range(4)])[same.rows]
    q2 = np.column_stack([moved.columns[f"q{i}"] for i in range(4)])[pos][same.rows]
    assert np.median(np.degrees(quat_angle(q1, q2))) < 0.3
    assert moved.rows.sum() == same.rows.sum()
