"""Segment orientations as an OpenSim OpenSense orientations file (``.sto``, ``DataType=Quaternion``).

The layout OpenSim's ``STOFileAdapterQuaternion`` / ``TimeSeriesTableQuaternion`` reads (version 3): a name
line, ``DataRate=``, ``DataType=Quaternion``, ``version=3``, ``OpenSimVersion=``, ``endheader``, then a
tab-separated table whose first column is ``time`` [s] and every other column one frame (``pelvis_imu``,
``torso_imu``, ... as OpenSense names its IMU frames) holding the quaternion ``w,x,y,z`` that rotates the
frame's vectors into the ground frame.

Frames in OpenSim's convention (ground: x forward, y up, z right): the body model's frame J (x forward,
y right, z down) and each segment's frame (x forward, y right, z down when upright) are both re-expressed
with ``P = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]`` (x, y, z)_J -> (x, -z, y): each rotation becomes
``P C P^T``.  In the calibration posture every segment is then the identity, as OpenSim's default pose.
"""

from __future__ import annotations

from typing import Any

import numpy as np

P = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _quat_wxyz(r: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    xyzw = Rotation.from_matrix(r).as_quat()
    q = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def opensense_text(t: np.ndarray, rot: dict[str, np.ndarray], name: str = "sportfusion body-model") -> str:
    """The ``.sto`` text for times ``t`` [s] and segment -> J rotations (n, 3, 3) (module text)."""
    t = np.asarray(t, float)
    rate = 1.0 / float(np.median(np.diff(t))) if t.size > 1 else 0.0
    cols = list(rot)
    quats = [_quat_wxyz(np.einsum("ij,njk,lk->nil", P, rot[c], P)) for c in cols]
    head = [name, f"DataRate={rate:.6f}", "DataType=Quaternion", "version=3", "OpenSimVersion=4.5", "endheader"]
    lines = ["\t".join(["time"] + [f"{c}_imu" for c in cols])]
    for i in range(t.size):
        lines.append("\t".join([f"{t[i]:.6f}"] + [",".join(f"{v:.10g}" for v in q[i]) for q in quats]))
    return "\n".join(head + lines) + "\n"


def write_opensense(path: Any, t: np.ndarray, rot: dict[str, np.ndarray]) -> None:
    """Write :func:`opensense_text` to ``path`` (a file name or a binary file object)."""
    data = opensense_text(t, rot).encode()
    if hasattr(path, "write"):
        path.write(data)
    else:
        with open(path, "wb") as fh:
            fh.write(data)
