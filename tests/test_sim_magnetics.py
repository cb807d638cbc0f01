"""The simulation toolkit's magnetic sources and sensor errors (sportfusion.sim.magnetics, .sensors): physics
properties -- far field of a bar magnet = the point dipole, curl-free (B = -grad phi), divergence-free
(Gauss: no net flux out of a closed surface), sizes of induced iron -- and the sensor error model's
scale, bias, quantisation, range, temperature and band-limited vibration."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.sim.magnetics import (
    M_N42,
    MU0_4PI,
    Anomaly,
    bar_magnet,
    iron_rod,
    point_dipole_charges,
    rod_pole_for_field,
    two_charge_magnet,
)
from sportfusion.sim.sensors import TriadSpec, band_noise, temperature_profile


def dipole_ut(r: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Point dipole written here from the textbook formula (not the estimator's): mu0/4pi (3(m.u)u - m)/r^3 [uT]."""
    d = np.linalg.norm(r, axis=-1, keepdims=True)
    u = r / d
    return MU0_4PI * 1e6 * (3 * np.sum(m * u, axis=-1, keepdims=True) * u - m) / d**3


def random_directions(n: int, seed: int = 0) -> np.ndarray:
    u = np.random.default_rng(seed).normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


@pytest.mark.parametrize("model", ["stack", "two-charge"])
def test_bar_magnet_tends_to_the_dipole_far_away(model):
    axis = np.array([0.1, -0.2, 1.0])
    m = 32.0
    src = bar_magnet(np.zeros(3), axis, m) if model == "stack" else two_charge_magnet(np.zeros(3), axis, m, 0.145)
    assert np.allclose(src.moment, m * axis / np.linalg.norm(axis), rtol=1e-9)
    u = random_directions(50)
    errs = []
    for r in (0.3, 0.6, 1.2, 3.0):
        b, d = src.field(r * u), dipole_ut(r * u, src.moment)
        errs.append(np.max(np.linalg.norm(b - d, axis=1) / np.linalg.norm(d, axis=1)))
    # the quadrupole vanishes (symmetric bar): the error falls like (L/r)^2 -- 30 % at 0.3 m, < 1 % at 3 m
    assert errs[0] > 0.05 and errs[-1] < 0.01
    assert all(a > b for a, b in zip(errs[:-1], errs[1:], strict=False))
    assert errs[2] / errs[3] > 0.8 * (3.0 / 1.2) ** 2


def test_the_paper_stack_has_its_moment_and_a_stronger_near_field_than_the_dipole():
    from sportfusion.gates.sim_sensors import STACK_LENGTH, STACK_MOMENT

    assert STACK_MOMENT == pytest.approx(10 * M_N42 * np.pi * 0.01**2 * 0.01)
    assert 30 < STACK_MOMENT < 35 and STACK_LENGTH == pytest.approx(0.145)
    src = bar_magnet(np.zeros(3), [0, 0, 1.0], STACK_MOMENT)
    p = np.array([[0.0, 0.0, 0.3]])  # on the axis, 0.3 m from the centre: 0.23 m from the top disc
    assert np.linalg.norm(src.field(p)) > 1.1 * np.linalg.norm(dipole_ut(p, src.moment))


def test_field_is_curl_free_minus_the_gradient_of_the_potential():
    src = bar_magnet(np.array([0.0, 0.0, 0.1]), np.array([0.3, 0.0, 1.0]), 30.0) + iron_rod(
        np.array([2.0, 1.0, -8.0]), np.array([2.0, 1.0, 0.0]), 50.0
    )
    p = 0.4 + random_directions(20, 1) * 0.5
    h = 1e-5
    grad = np.stack([(src.potential(p + h * e) - src.potential(p - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    b = src.field(p)
    assert np.allclose(b, -grad, rtol=1e-5, atol=1e-6 * np.abs(b).max())


def test_no_net_flux_out_of_a_closed_surface():
    # Gauss's law for B: the charges of a magnet sum to zero, so the flux through a sphere around it is 0,
    # while the flux of one pole alone is mu0/4pi * 4 pi q (here in uT m^2)
    src = bar_magnet(np.zeros(3), np.array([0.0, 0.0, 1.0]), 30.0)
    n_th, n_ph, rad = 200, 400, 0.2
    th = (np.arange(n_th) + 0.5) * np.pi / n_th
    ph = (np.arange(n_ph) + 0.5) * 2 * np.pi / n_ph
    T, P = np.meshgrid(th, ph, indexing="ij")
    nrm = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    da = (rad**2 * np.sin(T) * (np.pi / n_th) * (2 * np.pi / n_ph)).ravel()
    flux = np.sum(np.sum(src.field(rad * nrm) * nrm, axis=1) * da)
    pole = two_charge_magnet(np.array([0.0, 0.0, 0.5]), [0, 0, 1.0], 30.0, 1.0)  # +30 A m at z = 1, -30 at z = 0
    flux_pole = np.sum(np.sum(pole.field(rad * nrm) * nrm, axis=1) * da)  # the sphere holds the -30 A m pole
    expected = MU0_4PI * 1e6 * 4 * np.pi * -30.0
    assert abs(flux) < 1e-3 * abs(expected)
    assert flux_pole == pytest.approx(expected, rel=1e-3)


def test_iron_rod_is_sized_by_its_anomaly():
    pole = rod_pole_for_field(2.0, 5.0)
    rod = iron_rod(np.array([0.0, 0.0, -100.0]), np.zeros(3), pole, spread=0.0, points=1)  # far end far away
    b = rod.field(np.array([[5.0, 0.0, 0.0]]))
    assert np.linalg.norm(b) == pytest.approx(2.0, rel=0.01)
    assert np.allclose(rod.q.sum(), 0.0)


def test_point_dipole_charges_and_anomaly_are_small_and_smooth():
    obj = point_dipole_charges(np.zeros(3), np.array([0.0, 5.0, 0.0]))
    p = np.array([[0.0, 1.0, 0.3]])
    assert np.allclose(obj.field(p), dipole_ut(p, np.array([0.0, 5.0, 0.0])), rtol=1e-3)
    an = Anomaly.random(np.random.default_rng(0), (np.array([0, -50, 0.0]), np.array([700, 50, 0.0])), 0.3)
    x = np.column_stack([np.linspace(0, 700, 701), np.zeros(701), np.zeros(701)])
    b = an.field(x)
    assert 0.05 < np.abs(b).max() < 3.0  # a few hundred nT
    assert np.abs(np.diff(b, axis=0)).max() < 0.05  # smooth: under 50 nT per metre


def test_triad_errors():
    spec = TriadSpec(bias=0.1, scale=0.02, misalignment=0.01, noise=0.0, resolution=0.01, range=5.0, temp_bias=0.01)
    rng = np.random.default_rng(3)
    tri = spec.draw(rng)
    x = np.tile([1.0, -2.0, 0.5], (100, 1))
    t = np.arange(100) * 0.01
    y = tri.measure(t, x, rng)
    expect = (np.eye(3) + tri.misalignment) @ x[0] * (1 + tri.scale) + tri.bias
    assert np.allclose(y[0], np.round(expect / 0.01) * 0.01, atol=1e-9)
    assert np.allclose(y / 0.01, np.round(y / 0.01))  # quantised
    hot = tri.measure(t, x, rng, temperature=np.full(100, 30.0), t_ref=20.0)
    assert np.allclose(hot[0] - y[0], 10 * tri.temp_bias, atol=0.011)
    assert np.abs(tri.measure(t, 100 * x, rng)).max() <= 5.0  # the range clips
    walk = TriadSpec(bias_walk=0.1).draw(rng).measure(np.arange(10001) * 0.01, np.zeros((10001, 3)), rng)
    assert np.diff(walk, axis=0).std() == pytest.approx(0.1 * np.sqrt(0.01), rel=0.05)  # 0.1 u/sqrt(s)


def test_band_noise_and_temperature():
    rng = np.random.default_rng(0)
    x = band_noise(rng, 20000, 500.0, (8.0, 60.0), 1.5)
    assert np.allclose(x.std(axis=0), 1.5)
    spec = np.abs(np.fft.rfft(x[:, 0])) ** 2
    f = np.fft.rfftfreq(20000, 1 / 500.0)
    assert spec[(f < 7.9) | (f > 60.1)].sum() < 1e-9 * spec.sum()
    tt = np.array([0.0, 5.0, 125.0, 500.0, 600.0])
    temp = temperature_profile(tt, 5.0, 500.0, 20.0, -5.0, tau=120.0)
    assert temp[0] == temp[1] == 20.0 and temp[-1] == temp[-2]
    assert temp[2] == pytest.approx(-5 + 25 * np.exp(-1.0))
