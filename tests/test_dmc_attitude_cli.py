"""``dmc-attitude`` end to end on simulated ski runs: accuracy vs truth, options, error lines."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.magfield import inclination_declination, reference_field
from sportfusion.core.rotations import body_rates, quat_angle
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


@pytest.fixture(scope="module")
def smoothed(sim):
    """The session through spline-smooth: the GNSS acceleration ax ay az for eq 9."""
    res = run_cli(["spline-smooth"], stdin=sim[1])
    assert res.returncode == 0, res.stderr
    return res.stdout


def test_high_dynamics_with_gnss_acceleration(sim, smoothed):
    """The DMC alone (--no-gyro), sample by sample, as in the paper."""
    s, data = sim
    out, err = cli(["dmc-attitude", "--no-gyro"], smoothed)
    assert "(DMC alone)" in err
    assert sfio.get_meta(out)["provenance"][-1]["params"]["method"] == "dmc"
    assert "bias_gyr_x" not in out.column_names and "std_yaw" not in out.column_names
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
    low_out, _ = cli(["dmc-attitude", "--no-gyro"], data)
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


@pytest.mark.slow
def test_gyro_stabilised_attitude(sim, smoothed):
    """With the simulated gyro: the attitude over the whole run, better than the DMC alone by far."""
    s, data = sim
    out, err = cli(["dmc-attitude"], smoothed)
    assert "(gyro-stabilised DMC)" in err and "converge" not in err and "gyroscope" not in err
    assert sfio.get_meta(out)["provenance"][-1]["params"]["method"] == "gyro+dmc"
    rows, e = errors_deg(out, s.truth)
    t = floats(out, "t")[rows]
    run = t > 6.0  # free fall included: the gyro carries the attitude through the jumps
    med, p90 = np.median(e[run]), np.percentile(e[run], 90)
    dmc, _ = cli(["dmc-attitude", "--no-gyro"], smoothed)
    _, e_dmc = errors_deg(dmc, s.truth)
    sing = dmc.column("dmc_singular").to_numpy(zero_copy_only=False)[rows].astype(bool)
    print(
        f"high dynamics, gyro-stabilised: median {med:.2f} deg, 90th percentile {p90:.2f} deg "
        f"(DMC alone: median {np.median(e_dmc[run & ~sing]):.2f} deg without the singular rows)"
    )
    assert med < 1.0 and p90 < 1.5 and e.max() < 5.0
    assert np.median(e_dmc[run & ~sing]) > 2 * med
    # the DMC's per-sample diagnostics are kept
    np.testing.assert_array_equal(floats(out, "quest_loss"), floats(dmc, "quest_loss"))
    assert out.column("dmc_singular").equals(dmc.column("dmc_singular"))
    # the gyro bias (simulated: 0.01 rad/s 1-sigma turn-on plus a slow walk) and 1-sigma columns
    bias = np.column_stack([floats(out, f"bias_gyr_{a}") for a in "xyz"])[rows]
    gyr = np.column_stack([floats(s.session, f"gyr_{a}") for a in "xyz"])[rows]
    true_bias = (gyr - body_rates(t, quats(s.truth, "true_")[rows]))[t < 5.0].mean(axis=0)  # standing
    np.testing.assert_allclose(bias[t < 5.0].mean(axis=0), true_bias, atol=2e-3)
    assert out.schema.field("bias_gyr_x").metadata[b"unit"] == b"rad/s"
    std = np.column_stack([floats(out, f"std_{a}") for a in ("roll", "pitch", "yaw")])[rows]
    assert out.schema.field("std_yaw").metadata[b"unit"] == b"rad"
    assert np.all(std > 0) and np.median(std) < np.radians(1.0)
    # the DMC alone is exactly what a session without gyro columns gives
    spl = sfio.table_from_bytes(smoothed)
    bare = sfio.table_to_bytes(spl.drop_columns(["gyr_x", "gyr_y", "gyr_z"]), sfio.get_meta(spl))
    nogyro, err2 = cli(["dmc-attitude"], bare)
    assert "(DMC alone)" in err2
    for name in ("q0", "q1", "q2", "q3", "ax_dmc", "dmc_singular", "mag_implausible"):
        assert nogyro.column(name).equals(dmc.column(name)), name


def test_gyro_low_dynamics_uses_only_quiet_samples(sim, low):
    """No GNSS acceleration: f = -g only where the sensor is quiet; the gyro and the field carry the run."""
    s, _ = sim
    out, err = low
    assert sfio.get_meta(out)["provenance"][-1]["params"]["method"] == "gyro+dmc"
    rows, e = errors_deg(out, s.truth)
    t = floats(out, "t")[rows]
    print(
        f"gyro, no GNSS: median attitude error {np.median(e[t < 5]):.2f} deg standing, {np.median(e[t > 6]):.2f} deg in the run"
    )
    # rows without GNSS keep a loose f = -g tilt reference (docs/dmc-attitude.md): 0.99 deg in the run on seed 1
    assert np.median(e[t < 5.0]) < 1.0 and np.median(e[t > 6.0]) < 3.0


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
    # the hard iron is estimated in the magnetometer's unit (the prior scaled by its norm over the model's
    # intensity); normalising every sample makes it not quite constant (|m| varies ~1 %): the same within 0.2 deg
    assert np.degrees(np.max(quat_angle(quats(out)[ok], quats(base)[ok]))) < 0.2
    assert out.schema.field("bias_mag_x").metadata[b"unit"] == b"1"
    assert out.schema.field("std_bias_mag_x").metadata[b"unit"] == b"1"
    assert base.schema.field("bias_mag_x").metadata[b"unit"] == b"uT"
    b_ut = np.array([floats(base, f"bias_mag_{a}")[ok][0] for a in "xyz"])
    b_1 = np.array([floats(out, f"bias_mag_{a}")[ok][0] for a in "xyz"])
    np.testing.assert_allclose(b_1 * np.median(np.linalg.norm(m, axis=1)[np.isfinite(m[:, 0])]), b_ut, atol=0.05)
    # without the hard iron only the direction is used: uT and normalised give one answer
    a0, _ = cli(["dmc-attitude", "--lowpass", "0", "--mag-bias-sigma", "0"], data)
    b0, _ = cli(["dmc-attitude", "--lowpass", "0", "--mag-bias-sigma", "0"], sfio.table_to_bytes(table, meta))
    assert np.max(quat_angle(quats(a0)[ok], quats(b0)[ok])) < 1e-9
    assert "bias_mag_x" not in b0.column_names
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


def test_instantaneous_gyro_samples(sim, smoothed):
    """A gyro that samples the rate at the instant (a phone): --gyro-samples instant averages each interval
    (trapezoid) and is closer to the truth than reading the samples as interval means (half a sample late)."""
    s, _ = sim
    spl = sfio.table_from_bytes(smoothed)
    t = floats(spl, "t")
    rows = np.isfinite(floats(spl, "gyr_x"))
    m = body_rates(t[rows], quats(s.truth, "true_")[rows])  # truth's interval means
    inst = np.column_stack([floats(spl, f"gyr_{a}") for a in "xyz"])[rows]
    inst[:-1] += 0.5 * (m[1:] - m[:-1])  # the same errors about the rate at the sample's instant
    for i, a in enumerate("xyz"):
        col = floats(spl, f"gyr_{a}").copy()
        col[rows] = inst[:, i]
        spl = spl.set_column(spl.schema.get_field_index(f"gyr_{a}"), f"gyr_{a}", pa.array(col))
    data = sfio.table_to_bytes(spl, sfio.get_meta(spl))
    med = {}
    for how in ("mean", "instant"):
        out, _ = cli(["dmc-attitude", "--gyro-samples", how], data)
        assert sfio.get_meta(out)["provenance"][-1]["params"]["gyro_samples"] == how
        r, e = errors_deg(out, s.truth)
        run = floats(out, "t")[r] > 6.0
        med[how] = (np.median(e[run]), np.percentile(e[run], 90))
    print(f"instantaneous gyro: read as instant {med['instant']}, as interval means {med['mean']} (median, p90 deg)")
    assert med["instant"][0] < med["mean"][0] and med["instant"][1] < med["mean"][1]


def test_gyro_sampling_from_the_metadata():
    """auto: a simulated session (or the raw files simulate exports) -> interval means; a recording -> instant."""
    from sportfusion.skirace.dmc import gyro_sampling

    assert gyro_sampling({"provenance": [{"tool": "simulate skirace"}]})[0] == "mean"
    sim_raw = {"provenance": [{"tool": "ingest"}], "sources": [{"device": {"deviceBrand": "sportfusion"}}]}
    assert gyro_sampling(sim_raw)[0] == "mean"
    phone = {
        "provenance": [{"tool": "ingest"}],
        "sources": [{"format": "phyphox", "device": {"deviceBrand": "Google"}}],
    }
    assert gyro_sampling(phone)[0] == "instant"
    assert gyro_sampling({"provenance": [{"tool": "ingest"}], "sources": [{"format": "csv"}]})[0] == "instant"
    assert gyro_sampling({})[0] == "mean"


@pytest.mark.slow
def test_hard_iron_recovered_on_a_simulated_run():
    """A known hard iron (2 uT, the simulator's own set to 0) on a tuning seed: the run's turns reveal it."""
    from sportfusion.skirace.dmc import dmc_session
    from sportfusion.skirace.track import smooth_track

    s = simulate_skirace(SkiRaceConfig(seed=12, mag_bias=0.0))
    T, meta = s.session, s.meta
    xyz = lambda p: np.column_stack([floats(T, f"{p}{a}") for a in "xyz"])  # noqa: E731
    t = floats(T, "t")
    az = meta["frame"]["azimuth_deg"]
    kw = {"azimuth_deg": az, "site": tuple(meta["frame"]["origin"]), "when": meta["time"]["epoch_utc"]}
    trk = smooth_track(t, xyz("gnss_"), floats(T, "gnss_fix"), xyz("std_gnss_"), azimuth_deg=az, lam=0.9)
    a_kin = np.column_stack([trk.columns[f"a{c}"] for c in "xyz"])
    hard = np.array([1.2, -0.8, 1.5])  # [uT]
    mag = xyz("mag_") + hard
    res = dmc_session(t, xyz("acc_"), mag, acc_kin=a_kin, gyr=xyz("gyr_"), sigma_mag_bias=2.0, **kw)
    est = np.array(res.info["bias_mag"])
    std = np.array([res.columns[f"std_bias_mag_{a}"][res.rows][0] for a in "xyz"])
    print("hard iron", est, "+-", std, "true", hard, "(plus the simulator's 0.5 % scale errors)")
    # the simulator's scale errors (0.5 % of ~45 uT) act like ~0.2 uT of orientation-dependent bias
    assert np.all(np.abs(est - hard) < 0.3) and np.all(std < 0.2)
    qt = np.column_stack([floats(s.truth, f"true_q{i}") for i in range(4)])
    q = np.column_stack([res.columns[f"q{i}"] for i in range(4)])[res.rows]
    e = np.degrees(quat_angle(q, qt[res.rows]))
    off = dmc_session(t, xyz("acc_"), mag, acc_kin=a_kin, gyr=xyz("gyr_"), sigma_mag_bias=0.0, **kw)
    e0 = np.degrees(quat_angle(np.column_stack([off.columns[f"q{i}"] for i in range(4)])[off.rows], qt[off.rows]))
    print(f"median attitude error {np.median(e):.2f} deg, hard iron not estimated {np.median(e0):.2f} deg")
    assert np.median(e) < 0.6 < 1.5 < np.median(e0)
    # --no-gyro: the DMC alone, untouched by the bias options
    a = dmc_session(t, xyz("acc_"), mag, use_gyro=False, sigma_mag_bias=2.0, **kw)
    b = dmc_session(t, xyz("acc_"), mag, use_gyro=False, sigma_mag_bias=0.0, sigma_acc_bias=0.0, **kw)
    np.testing.assert_array_equal(a.columns["q0"], b.columns["q0"])
    assert "bias_mag_x" not in a.columns and a.info["method"] == "dmc"
