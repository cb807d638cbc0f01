"""detect-events --kind gates: crossings, distance from the peak intensity, turn side; calibration; bad input."""

from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.gates.crossings import detect_gate_table, read_crossings
from sportfusion.gates.magnet import default_calibration, fit_calibration, refine_peak
from sportfusion.gates.sim import GatesConfig, simulate_gates


@pytest.fixture(scope="module")
def sims():
    return [simulate_gates(GatesConfig(seed=s)) for s in (11, 12)]


def _score(sim, det):
    c = sim.crossings
    found, turn_ok, derr, spurious = 0, 0, [], 0
    for x in det.crossings:
        j = int(np.argmin(np.abs(c["t"] - x.t)))
        if abs(c["t"][j] - x.t) > 0.03:
            spurious += 1
            continue
        found += 1
        turn_ok += x.turn == c["turn"][j]
        derr.append(x.distance - c["distance"][j])
    return found, turn_ok, np.array(derr), spurious


def test_crossings_against_truth(sims):
    for sim in sims:
        det = detect_gate_table(sim.session)
        found, turn_ok, derr, spurious = _score(sim, det)
        n = sim.magnets.shape[0]
        near = int((sim.crossings["distance"] < 0.8).sum())
        assert found >= near - 1 and found <= n  # every pass closer than 0.8 m is detected (paper: ~0.80 m), one slack
        assert turn_ok == found  # the sign of gyr_z at the crossing gives the side
        assert spurious <= 3
        assert abs(np.median(derr)) < 0.08 and np.percentile(np.abs(derr), 90) < 0.25  # distance from |B| [m]


def test_refine_peak_recovers_a_cube_law_peak():
    # |B| excess of a pass at 0.5 m, 20 m/s, sampled at 125 Hz off the peak by 0.4 sample
    c, r0, v, dt = 0.08, 0.5, 20.0, 1 / 125
    tt = (np.arange(-5, 6) + 0.4) * dt
    b = 1 + c / (r0**2 + (v * tt) ** 2) ** 1.5
    k = int(np.argmax(b))
    true_peak = 1 + c / r0**3
    assert abs(refine_peak(b, k) - true_peak) < 0.3 * abs(b[k] - true_peak)


def test_fit_calibration_recovers_the_constant():
    d = np.linspace(0.3, 1.0, 8)
    cal = fit_calibration(d, 1 + 0.05 / d**3)
    assert cal.c == pytest.approx(0.05, rel=1e-9)
    assert np.allclose(cal.distance(cal.peak(d)), d)
    assert default_calibration().c > 0


def test_cli_gates_with_user_calibration(tmp_path, sims):
    sim = sims[0]
    data = sfio.table_to_bytes(sim.session, sim.meta)
    d = np.array([0.3, 0.5, 0.8, 1.0])
    (tmp_path / "cal.csv").write_text("distance,peak\n" + "\n".join(f"{a},{1 + 0.04 / a**3}" for a in d))
    r = run_cli(["detect-events", "--kind", "gates", "--magnet-calibration", str(tmp_path / "cal.csv")], stdin=data)
    assert r.returncode == 0, r.stderr
    out, meta = sfio.read_table(io.BytesIO(r.stdout))
    cr = read_crossings(out)
    bp = out.column("gate_b_peak").to_numpy(zero_copy_only=False)[cr["row"]]
    assert np.allclose(cr["distance"], np.cbrt(0.04 / (bp - 1)))
    assert meta["events"][-1]["kind"] == "gates" and "user table" in meta["events"][-1]["calibration"]["source"]
    assert set(out.column("turn").drop_null().to_pylist()) == {"L", "R"}
    assert out.num_rows == sim.session.num_rows and {"acc_x", "mag_x"} <= set(out.column_names)


def test_no_magnetometer_is_one_clear_line():
    data = session_bytes({"acc_x": np.zeros(20), "gyr_z": np.zeros(20)})
    r = run_cli(["detect-events", "--kind", "gates"], stdin=data)
    assert r.returncode == 1 and r.stdout == b""
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and "no magnetometer" in lines[0]


def test_bad_calibration_table(tmp_path, sims):
    (tmp_path / "cal.csv").write_text("0.5,0.9\n")
    data = sfio.table_to_bytes(sims[0].session.slice(0, 500), sims[0].meta)
    r = run_cli(["detect-events", "--kind", "gates", "--magnet-calibration", str(tmp_path / "cal.csv")], stdin=data)
    assert r.returncode == 1 and "calibration" in r.stderr.decode()


def test_peak_time_between_samples():
    """A magnet passed at 23 m/s, 0.6 m below and 0.2 m beside, sampled at 100 Hz from random phases: the peak
    time interpolated on log(b - 1) is within 1.5 ms of the continuous |B| peak (the sampled maximum: up to
    5 ms, 0.12 m along the track)."""
    from sportfusion.gates.magnet import dipole_field, peak_vertex

    rng = np.random.default_rng(4)
    earth = np.array([21.5, 0.6, 42.5])
    err_refined, err_sample = [], []
    for _ in range(20):
        t0 = rng.uniform(0.0, 0.01)
        t = t0 + np.arange(-0.3, 0.3, 0.01)
        fine = np.arange(-0.3, 0.3, 1e-5)

        def b(tq):
            pos = np.column_stack([23.0 * tq, np.full_like(tq, 0.2), np.full_like(tq, -0.6)])
            return np.linalg.norm(earth + dipole_field(pos, np.array([0.0, 0.0, 30.0])), axis=1) / np.linalg.norm(earth)

        t_true = fine[np.argmax(b(fine))]
        bs = b(t)
        k = int(np.argmax(bs))
        dk, _ = peak_vertex(bs, k)
        err_refined.append(abs(t[k] + dk * 0.01 - t_true))
        err_sample.append(abs(t[k] - t_true))
    assert max(err_refined) < 0.0015 and max(err_sample) > 0.003, (max(err_refined), max(err_sample))


def test_magnets_buried_north_pole_up_are_found_by_their_vector_anomaly():
    # north pole up, the magnet lowers |B| right above it (a dip); the field's anomaly in a ground-fixed
    # frame (the gyro carries it there) is a peak whatever the polarity
    from sportfusion.gates.crossings import GateParams

    sim = simulate_gates(GatesConfig(seed=13, variant="flipped", n_gates=8, static=2.0))
    c = sim.crossings
    near = c["distance"] < 0.8

    def found(det):
        return np.array([np.any(np.abs(np.array([x.t for x in det.crossings]) - tc) < 0.05) for tc in c["t"]])

    with_anomaly = found(detect_gate_table(sim.session))
    intensity_only = found(detect_gate_table(sim.session, GateParams(anomaly=False)))
    assert with_anomaly[near].all()
    assert intensity_only[near].sum() < near.sum()  # the dips the intensity search misses
