"""The climbing particle filter's C path (``climbing/_climbing_c.c``) against its numpy reference.

Both draw the same random numbers, so the filter's outputs agree to rounding and the smoother picks the
same trajectories; the step-by-step references in ``test_climbing_particles.py`` check whichever path is
built, these tests check that the two paths agree.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator

import numpy as np
import pytest

from sportfusion.climbing import _native
from sportfusion.climbing import particles as pf
from sportfusion.climbing.particles import PFParams, PFResult

C = _native.native()
needs_c = pytest.mark.skipif(C is None, reason="the C extension sportfusion.climbing._climbing_c is not built")
UP = np.array([0.0, 0.0, 1.0])


@pytest.fixture
def engines() -> Iterator[dict]:
    """Run a function with the numpy path and with the C path; the module's choice restored after."""
    saved = _native._NATIVE

    def both(fn):  # noqa: ANN001, ANN202
        out = {}
        for name, mod in (("numpy", None), ("c", C)):
            _native._NATIVE = mod
            out[name] = fn()
        return out

    yield both
    _native._NATIVE = saved


def _same(a: PFResult, b: PFResult, smooth: bool = True) -> None:
    assert (a.k0, a.resamples, a.merged_at) == (b.k0, b.resamples, b.merged_at)
    k = a.k0
    for name in ("pos", "prob", "yaw", "log_evidence"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.isnan(x[:k]).all() and np.isnan(y[:k]).all(), name
        assert np.allclose(x[k:], y[k:], rtol=1e-12, atol=1e-9), name
    assert np.array_equal(a.label, b.label)
    assert np.allclose(a.start_evidence, b.start_evidence, rtol=1e-12, atol=1e-8)
    if smooth:
        assert np.array_equal(a.smooth_label, b.smooth_label)
        assert np.allclose(a.smooth_pos[k:], b.smooth_pos[k:], rtol=0, atol=1e-9)
        assert np.allclose(a.smooth_prob[k:], b.smooth_prob[k:], rtol=0, atol=1e-12)


def test_the_extension_is_built_where_a_compiler_is() -> None:
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler here")
    if os.environ.get("SPORTFUSION_NATIVE") == "0":
        pytest.skip("SPORTFUSION_NATIVE=0: the fallback is asked for")
    assert C is not None, "sportfusion.climbing._climbing_c is not built: pip install -e . (make .venv/.installed)"


def _ladder(second_start_x: float = 0.5):
    """Start holds 0 (x=0) and 1; the hand starts on 0, climbs to 2 then 3; white velocity noise."""
    centres = np.array([[0.0, 0.0, 1.2], [second_start_x, 0.0, 1.2], [0.05, 0.0, 1.8], [-0.1, 0.0, 2.4]])
    ids = np.array([0, 1, 2, 3])
    rng = np.random.default_rng(7)
    dt = 0.02
    t, p, grip, t0 = [], [], [], 0.0
    for i, h in enumerate((0, 2, 3)):
        tg = t0 + np.arange(0, 1.0, dt)
        t.append(tg), p.append(np.repeat(centres[h][None] + [0, -0.05, 0], tg.size, axis=0)), grip.append(tg > -1)
        t0 = tg[-1] + dt
        if i < 2:
            tm = t0 + np.arange(0, 0.6, dt)
            s = (tm - t0) / 0.6
            a, b = centres[h], centres[(0, 2, 3)[i + 1]]
            t.append(tm), p.append(a + [0, -0.05, 0] + (s**3 * (10 - 15 * s + 6 * s * s))[:, None] * (b - a))
            grip.append(tm < -1)
            t0 = tm[-1] + dt
    t, p, grip = np.concatenate(t), np.concatenate(p), np.concatenate(grip)
    v = np.gradient(p, t, axis=0) + rng.normal(0, 0.05, p.shape)
    cov = np.repeat((0.03**2 * np.eye(3))[None], t.size, axis=0)
    grip[:3] = False  # the filter starts at the first grip
    return t, v, cov, grip, (ids, centres), (ids[:2], centres[:2])


@needs_c
@pytest.mark.parametrize(
    "second_start_x, params",
    [
        (0.5, PFParams(particles=60, ess_fraction=0.97)),  # strata that never meet, resampled often
        (0.12, PFParams(particles=60, ess_fraction=0.97)),  # strata that merge at hold 2
        (0.12, PFParams(particles=60, grip_count=2.0)),  # tempered grips
        (0.5, PFParams(particles=50, separate_starts=False, smoother_moves=3)),  # one set, three moves
    ],
)
def test_c_path_equals_the_numpy_filter_and_smoother(engines, second_start_x: float, params: PFParams) -> None:
    t, v, cov, grip, route, start = _ladder(second_start_x)
    out = engines(lambda: pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=3))
    _same(out["numpy"], out["c"])
    assert out["c"].resamples > 0
    if params.separate_starts:
        assert (out["c"].merged_at > 0) == (second_start_x < 0.3)


@needs_c
def test_c_path_equals_numpy_on_a_simulated_trial_with_descent(engines) -> None:
    """A simulated bouldering trial through the transition estimator: route holds, then the wall's."""
    from sportfusion.climbing.grips import grip_columns
    from sportfusion.climbing.holds import validate
    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
    from sportfusion.climbing.track import track_holds
    from sportfusion.core.session import with_columns

    sim = simulate_boulder(BoulderConfig(seed=31, duration=20.0))
    holds = validate(sim.holds, sim.holds_meta)
    table = with_columns(sim.session, grip_columns(sim.session)[0])
    out = engines(lambda: track_holds(table, sim.meta, holds).pf)
    _same(out["numpy"], out["c"])
    assert out["c"].resamples > 10


@needs_c
def test_complementary_filter_loop_equals_the_python_loop(engines) -> None:
    from sportfusion.climbing.orientation import complementary_filter

    rng = np.random.default_rng(5)
    n = 400
    t = np.cumsum(rng.uniform(0.008, 0.012, n))
    acc = rng.normal([0.0, 0.0, 9.81], 2.0, (n, 3))
    gyr = rng.normal(0.0, 1.5, (n, 3))
    mag = rng.normal([0.3, 0.0, -0.9], 0.1, (n, 3))
    mag[50:60] = np.nan  # no magnetometer sample: no field correction there
    out = engines(lambda: complementary_filter(t, acc, gyr, mag, np.array([0.4, 0.0, -0.9]), UP, 9.81, gyr[0]))
    assert np.allclose(out["numpy"], out["c"], rtol=0, atol=1e-12)
    assert np.allclose(out["c"] @ np.swapaxes(out["c"], 1, 2), np.eye(3), atol=1e-12)


@needs_c
def test_bad_dimensions_are_refused() -> None:
    z = np.zeros(3)
    with pytest.raises(ValueError, match="bad dimensions"):
        C.forward(0, 10, 0, 1, 0, 1, 1, 1, 0.1, 0.05, 1.0, 0.0, 0.5, *([z] * 31), None, 1, 0, 1, z)
    with pytest.raises(ValueError, match="bad dimensions"):
        C.backward_paths(1, 10, 0, 1, *([z] * 12))
    with pytest.raises(ValueError, match="expected"):  # a wrong length: the C side checks every buffer
        C.backward_paths(3, 2, 0, 1, *([z] * 12))
    with pytest.raises(ValueError, match="expected"):
        C.complementary(5, *([z] * 10))
    # a hold code beyond the cluster table is refused, not read out of bounds
    t, v, cov, grip, route, start = _ladder()
    ids, centres = route
    orig = C.forward
    args = {}

    def capture(*a):  # noqa: ANN002, ANN202
        args["a"] = list(a)
        return orig(*a)

    class Spy:
        forward = staticmethod(capture)

        def __getattr__(self, name: str):  # noqa: ANN204
            return getattr(C, name)

    saved = _native._NATIVE
    _native._NATIVE = Spy()
    try:
        pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=20), seed=1, smooth=False)
    finally:
        _native._NATIVE = saved
    a = args["a"]
    a[13 + 12] = np.full_like(a[13 + 12], a[3])  # r_code = ncodes
    with pytest.raises(ValueError, match="out of range"):
        C.forward(*a)


@needs_c
@pytest.mark.parametrize("first_grip", ["last", "second_last"])
def test_c_path_with_the_first_grip_at_the_end(engines, first_grip: str) -> None:
    """The filter starts at the last or second-to-last sample: no step to predict, or one."""
    t, v, cov, grip, route, start = _ladder()
    grip = np.zeros_like(grip)
    grip[-1 if first_grip == "last" else -2] = True
    params = PFParams(particles=20)
    out = engines(lambda: pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=1))
    _same(out["numpy"], out["c"])
    assert np.isfinite(out["c"].smooth_pos[-1]).all()


@needs_c
def test_transition_blocks_equal_the_numpy_ones(engines) -> None:
    """The transition estimator's dynamic-model residuals, Jacobian blocks and normal equations in C equal
    numpy's: large and tiny rotations per step (the series branches), relative turns near a half turn
    (Shepperd's other cases), saturated samples and magnetometer gaps."""
    from scipy.spatial.transform import Rotation

    from sportfusion.climbing import transition as tr

    rng = np.random.default_rng(17)
    n = 300
    t = np.cumsum(rng.uniform(0.008, 0.012, n))
    gyr = rng.normal(0.0, 2.0, (n, 3))
    gyr[::7] *= 1e-6  # |w dt| below 1e-5 rad
    acc = rng.normal([0.0, 0.0, 9.81], 3.0, (n, 3))
    mag = rng.normal([0.3, 0.0, -0.9], 0.1, (n, 3))
    mag[40:50] = np.nan
    grip = rng.uniform(size=n) < 0.2
    sat = rng.uniform(size=n) < 0.05
    prob = tr.Problem(
        t, acc, gyr, mag, grip, sat, np.array([0.4, 0.0, -0.9]), np.array([0.0, 0.0, -9.81]), tr.TransitionParams()
    )
    r = Rotation.random(n, random_state=3).as_matrix()
    r[100:120] = r[99]  # relative rotations near the identity
    for k in range(200, 220):  # ... and near half turns about each axis
        r[k] = r[k - 1] @ Rotation.from_rotvec(np.eye(3)[k % 3] * (np.pi - 1e-3 * (k % 5))).as_matrix()
    st = tr.State(r, rng.normal(0.0, 1.0, (n, 3)), rng.normal(0.0, 0.05, 9))

    def run():  # noqa: ANN202
        lin = tr.linearize(prob, st)
        return lin, tr.normal_equations(prob, lin)

    out = engines(run)
    (la, na), (lb, nb) = out["numpy"], out["c"]
    for name in ("r_dyn", "r_mag", "r_zupt", "r_prior", "ja", "jb", "jc", "jm"):
        np.testing.assert_allclose(getattr(lb, name), getattr(la, name), rtol=1e-10, atol=1e-9, err_msg=name)
    assert lb.cost == pytest.approx(la.cost, rel=1e-12)
    for name in ("hd", "ho", "hxb", "hbb", "gx", "gb"):
        a, b = getattr(na, name), getattr(nb, name)
        np.testing.assert_allclose(b, a, rtol=1e-10, atol=1e-9 * np.abs(a).max(), err_msg=name)
    with pytest.raises(ValueError, match="expected"):  # buffers of the wrong size are refused
        outs = (np.empty((n - 1, 6)), np.empty((n - 1, 6, 6)), np.empty((n - 1, 6, 6)), np.empty((n - 1, 6, 9)))
        C.transition_blocks(n - 1, prob.dt[:-1], gyr, acc, r, st.v, st.b, prob.sig_dyn, prob.g_world, *outs)
    with pytest.raises(ValueError, match="expected"):
        C.normal_blocks(n - 1, la.ja, la.jb, la.jc, la.r_dyn, *(np.empty(3) for _ in range(6)))


@needs_c
@pytest.mark.parametrize(
    "params",
    [
        PFParams(particles=60, ess_fraction=0.97),
        PFParams(particles=50, separate_starts=False, smoother_moves=3, ess_fraction=0.9),
    ],
)
def test_c_path_in_blocks_equals_the_whole_run(engines, monkeypatch: pytest.MonkeyPatch, params: PFParams) -> None:
    """The C path draws its process noise and runs its smoother a block of steps at a time (issue 38's memory):
    blocks of 1 and 7 steps give the outputs of one block over the whole trial to the bit, and the numpy
    reference's (which draws everything at once) to rounding."""
    from sportfusion.climbing import _pfblocks

    t, v, cov, grip, route, start = _ladder(0.12)
    runs = {}
    for block in (1, 7, 10**9):
        monkeypatch.setattr(_pfblocks, "BLOCK", block)
        runs[block] = engines(lambda: pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=3))
    whole = runs[10**9]["c"]
    for block in (1, 7):
        c = runs[block]["c"]
        for name in ("pos", "label", "prob", "yaw", "log_evidence", "smooth_pos", "smooth_label", "smooth_prob"):
            assert np.array_equal(getattr(c, name), getattr(whole, name), equal_nan=True), (block, name)
        _same(runs[block]["numpy"], c)
    assert whole.resamples > 0 and t.size > 100


@needs_c
def test_c_forward_refuses_a_bad_noise_callback_or_block() -> None:
    """The noise callback's error comes back as the call's exception; a noise block below 1 step and a block of
    steps the loop cannot resume at are refused."""
    t, v, cov, grip, route, start = _ladder()
    args = {}

    class Spy:
        def forward(self, *a):  # noqa: ANN002, ANN202
            args["a"] = list(a)
            return C.forward(*a)

        def __getattr__(self, name: str):  # noqa: ANN204
            return getattr(C, name)

    saved = _native._NATIVE
    _native._NATIVE = Spy()
    try:
        pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=20), seed=1, smooth=False)
    finally:
        _native._NATIVE = saved
    a = args["a"]

    def broken(j: int) -> None:
        raise RuntimeError(f"no noise for step {j}")

    refill, block, kb, ke, state = a[-5:]
    assert (kb, ke) == (int(np.argmax(grip)), t.size) and block >= 1  # one block over this short trial
    with pytest.raises(RuntimeError, match="no noise for step 0"):
        C.forward(*a[:-5], broken, block, kb, ke, state)
    with pytest.raises(ValueError, match="refill"):
        C.forward(*a[:-5], refill, 0, kb, ke, state)
    # a later block must start at a noise block, with the noise drawn by a callback; the block within the trial
    for bad in (
        (None, block, kb + 1, ke),
        (refill, 4, kb + 2, ke),
        (refill, block, kb, ke + 1),
        (refill, block, kb, kb),
    ):
        with pytest.raises(ValueError, match="bad block"):
            C.forward(*a[:-5], *bad, state)


@needs_c
def test_c_filter_with_ffbsm_keeps_the_whole_history(engines, monkeypatch: pytest.MonkeyPatch) -> None:
    """FFBSm reads the filter's whole history: the C loop then runs as one block over full-length buffers
    (blocks of 5 steps asked for), and its smoother's outputs equal the numpy path's."""
    from sportfusion.climbing import _pfblocks

    monkeypatch.setattr(_pfblocks, "BLOCK", 5)
    t, v, cov, grip, route, start = _ladder(0.12)
    params = PFParams(particles=40, smoother="ffbsm", ess_fraction=0.9)
    out = engines(lambda: pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=2))
    _same(out["numpy"], out["c"])
    assert out["c"].resamples > 0 and np.isfinite(out["c"].smooth_pos[out["c"].k0 :]).all()
