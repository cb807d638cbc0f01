"""The body model against OpenSim (the field's reference tool): the same seven-segment chain built in OpenSim
with our lengths and masses and posed with our joint angles gives the same centre of mass
(``Model.calcMassCenterPosition``, within 1 mm), and ``body-model --opensense`` writes an orientations file
OpenSim's own reader loads.  Skipped where the optional ``opensim`` package is not installed
(``pip install 'sportfusion[opensim]'``; CI installs it with the test extra)."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.body.anthropometry import PARENT, SEGMENTS, body_params
from sportfusion.body.model import centre_of_mass, joint_rotations, rotation_from_xyz, xyz_angles
from sportfusion.body.opensense import opensense_text

osim = pytest.importorskip("opensim", reason="the optional opensim package (extra [opensim]) is not installed")


def _custom_joint(name, parent, location, child):
    st = osim.SpatialTransform()
    for i, ax in enumerate(([1, 0, 0], [0, 1, 0], [0, 0, 1])):
        for k, prefix in ((i, "r"), (3 + i, "t")):
            ta = st.updTransformAxis(k)
            ta.setCoordinateNames(osim.ArrayStr(f"{name}_{prefix}{i}", 1))
            ta.setAxis(osim.Vec3(*ax))
            ta.set_function(osim.LinearFunction())
    return osim.CustomJoint(name, parent, osim.Vec3(*location), osim.Vec3(0), child, osim.Vec3(0), osim.Vec3(0), st)


def _poses(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Random skiing-like segment orientations (segment -> J) for ``n`` instants."""
    out = {}
    for seg in SEGMENTS:
        ang = rng.uniform(-0.6, 0.6, (n, 3))
        if seg.startswith("femur"):
            ang[:, 1] += 1.0  # hip flexion
        out[seg] = rotation_from_xyz(ang)
    return out


def test_com_matches_opensim_calc_mass_center_position() -> None:
    body = body_params(1.83, 81.0, "male", equipment=12.0)
    model = osim.Model()
    bodies = {}
    for seg in SEGMENTS:
        m, c = body.com[seg]
        b = osim.Body(seg, float(m), osim.Vec3(*c), osim.Inertia(0.01, 0.01, 0.01))
        model.addBody(b)
        bodies[seg] = b
    joints = {"pelvis": _custom_joint("pelvis", model.getGround(), (0, 0, 0), bodies["pelvis"])}
    for seg in SEGMENTS[1:]:
        joints[seg] = _custom_joint(seg, bodies[PARENT[seg]], body.joint[seg], bodies[seg])
    for j in joints.values():
        model.addJoint(j)
    state = model.initSystem()
    rot = _poses(5, np.random.default_rng(3))
    ours = centre_of_mass(rot, body)
    rel = joint_rotations(rot)
    angles = {"pelvis": xyz_angles(rot["pelvis"]), **{k: xyz_angles(v) for k, v in rel.items()}}
    assert abs(model.getTotalMass(state) - body.total_mass) < 1e-9
    for i in range(ours.shape[0]):
        for seg, j in joints.items():
            for k in range(3):
                j.get_coordinates(k).setValue(state, float(angles[seg][i, k]), False)
                j.get_coordinates(3 + k).setValue(state, 0.0, False)
        model.realizePosition(state)
        c = model.calcMassCenterPosition(state)
        theirs = np.array([c.get(0), c.get(1), c.get(2)])
        assert np.linalg.norm(theirs - ours[i]) < 1e-3  # 1 mm
        # and the thigh's orientation is ours (the joint angles pose the same chain)
        r = bodies["femur_r"].getTransformInGround(state).R()
        r_os = np.array([[r.get(a, b) for b in range(3)] for a in range(3)])
        assert np.allclose(r_os, rot["femur_r"][i], atol=1e-9)


def test_opensense_orientations_file_loads_in_opensim(tmp_path) -> None:
    rng = np.random.default_rng(4)
    t = np.arange(20) / 100.0
    rot = _poses(t.size, rng)
    path = tmp_path / "orientations.sto"
    path.write_text(opensense_text(t, rot))
    table = osim.TimeSeriesTableQuaternion(str(path))
    labels = list(table.getColumnLabels())
    assert labels == [f"{s}_imu" for s in SEGMENTS]
    assert table.getNumRows() == t.size
    assert abs(float(table.getIndependentColumn()[5]) - t[5]) < 1e-9
    # the pelvis quaternion of row 5 is P C P^T (OpenSim's y-up ground), as a rotation
    q = table.getRowAtIndex(5).getElt(0, 0)
    w, x, y, z = q.get(0), q.get(1), q.get(2), q.get(3)
    r_os = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    p = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    assert np.allclose(r_os, p @ rot["pelvis"][5] @ p.T, atol=1e-8)
