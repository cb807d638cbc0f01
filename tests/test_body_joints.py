"""Joint centres from two IMUs (Seel et al. 2012) on exact rigid-body kinematics, and the pelvis sensor's lever
arm to the LJC against the independent skier's truth."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.body.joints import joint_centre
from sportfusion.core.rotations import dcm_from_quat, quat_from_rotvec


def _rotations(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Smooth segment -> world rotations (n, 3, 3): a rotation vector made of a few slow sines."""
    phi = np.zeros((t.size, 3))
    for j in range(3):
        for _ in range(3):
            phi[:, j] += rng.uniform(0.1, 0.6) * np.sin(2 * np.pi * rng.uniform(0.2, 1.5) * t + rng.uniform(0, 6))
    return np.swapaxes(dcm_from_quat(quat_from_rotvec(phi)), -1, -2)


def _rates(r: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame angular rate and its derivative of rotations (n, 3, 3) by finite differences."""
    w_m = np.einsum("nij,nkj->nik", np.gradient(r, dt, axis=0), r)  # dR R^T: [w]x in the world frame
    w = np.einsum("nji,nj->ni", r, np.stack([w_m[:, 2, 1], w_m[:, 0, 2], w_m[:, 1, 0]], -1))
    return w, np.gradient(w, dt, axis=0)


def test_joint_centre_recovers_both_lever_arms_on_exact_kinematics() -> None:
    rng = np.random.default_rng(5)
    dt = 0.002
    t = np.arange(0.0, 20.0, dt)
    r1, r2 = _rotations(t, rng), _rotations(t, rng)
    joint = np.column_stack([np.sin(0.7 * t), 0.5 * np.cos(0.3 * t), 0.2 * t])  # the joint moves freely
    o1, o2 = np.array([0.12, -0.05, 0.08]), np.array([0.01, 0.07, -0.22])  # joint in each sensor frame [m]
    g = np.array([0.0, 0.0, 9.81])
    forces, rates = [], []
    for r, o in ((r1, o1), (r2, o2)):
        pos = joint - np.einsum("nij,j->ni", r, o)  # the sensor
        acc = np.gradient(np.gradient(pos, dt, axis=0), dt, axis=0)
        forces.append(np.einsum("nji,nj->ni", r, acc - g))  # specific force, z down
        rates.append(_rates(r, dt))
    k = slice(5, -5, 5)  # away from the one-sided differences at the ends, 100 Hz
    fit = joint_centre(
        rates[0][0][k], rates[0][1][k], forces[0][k], rates[1][0][k], rates[1][1][k], forces[1][k],
        np.zeros(3), np.zeros(3),
    )  # fmt: skip
    assert np.linalg.norm(fit.o1 - o1) < 0.002 and np.linalg.norm(fit.o2 - o2) < 0.002, (fit.o1, fit.o2)
    assert fit.rms < 0.01


@pytest.mark.slow
def test_pelvis_lever_against_the_independent_skier(tmp_path) -> None:
    """The sacrum sensor sits ~0.1 m behind the LJC on the simulator's skier (strapped up to 30 deg off): the
    lever arm estimated from the hips has its length within 3 cm (measured: 1-2 cm on three runs)."""
    from conftest import run_cli

    from sportfusion.core import io as sfio
    from sportfusion.core import schema

    sim = run_cli(
        ["simulate", "gates", "--seed", "3", "--n-gates", "8", "--body", "-q", "--truth", str(tmp_path / "t.pq")]
    )
    assert sim.returncode == 0, sim.stderr
    body = run_cli(["body-model", "-q", "--height", "1.8", "--mass", "78"], sim.stdout)
    assert body.returncode == 0, body.stderr
    (tmp_path / "b.pq").write_bytes(body.stdout)
    _, meta = sfio.read_table(tmp_path / "b.pq")
    lever = np.asarray(meta["body_model"]["pelvis_lever_m"])
    truth, _ = sfio.read_table(tmp_path / "t.pq")
    d = schema.float_columns(truth, ["true_ljc_x", "true_ljc_y", "true_ljc_z"]) - schema.float_columns(
        truth, ["true_x", "true_y", "true_z"]
    )
    true_len = float(np.median(np.linalg.norm(d, axis=1)))
    assert abs(np.linalg.norm(lever) - true_len) < 0.03, (lever, true_len)
    assert lever[0] > 0.05  # the LJC is in front of the sacrum
    assert "estimated from the hip joint centres" in meta["body_model"]["pelvis_lever"]
