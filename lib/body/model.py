"""The body model: joint centres and the whole-body centre of mass relative to the lumbar joint centre.

Given each segment's orientation ``C_s`` (segment frame -> the body model's global frame J, a (n, 3, 3)
stack), the chain of :mod:`sportfusion.body.anthropometry` puts the LJC at the origin and every joint at its
parent's origin plus the parent's rotated joint offset (gates paper, "Body model": Fasel et al. 2017,
Front. Physiol. 8:850).  The CoM is the mass-weighted mean of the segments' CoMs (carried parts and
equipment included); the joint angles are the parent-to-child rotations.
"""

from __future__ import annotations

import numpy as np

from sportfusion.body.anthropometry import PARENT, SEGMENTS, BodyParams


def _apply(c: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("nij,j->ni", c, v)


def segment_origins(rot: dict[str, np.ndarray], body: BodyParams) -> dict[str, np.ndarray]:
    """Each segment's origin (its proximal joint centre) in J relative to the LJC [m], shape (n, 3)."""
    n = next(iter(rot.values())).shape[0]
    out: dict[str, np.ndarray] = {}
    for seg in SEGMENTS:
        if seg == "pelvis" or seg == "torso":
            out[seg] = np.zeros((n, 3))
            continue
        parent = PARENT[seg]
        out[seg] = out[parent] + _apply(rot[parent], body.joint[seg])
    return out


def body_points(rot: dict[str, np.ndarray], body: BodyParams) -> dict[str, np.ndarray]:
    """Joint centres and named points (:attr:`BodyParams.points`) in J relative to the LJC [m], (n, 3) each."""
    org = segment_origins(rot, body)
    return {name: org[seg] + _apply(rot[seg], p) for name, (seg, p) in body.points.items()}


def centre_of_mass(rot: dict[str, np.ndarray], body: BodyParams) -> np.ndarray:
    """Whole-body CoM (equipment included) in J relative to the LJC [m], shape (n, 3)."""
    org = segment_origins(rot, body)
    total = 0.0
    acc = np.zeros_like(org["pelvis"])
    for seg, (m, c) in body.com.items():
        acc += m * (org[seg] + _apply(rot[seg], c))
        total += m
    return acc / total


def joint_rotations(rot: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Parent -> child rotation of each joint, ``R = C_parent^T C_child`` (child frame -> parent frame)."""
    return {seg: np.einsum("nji,njk->nik", rot[PARENT[seg]], rot[seg]) for seg in SEGMENTS if seg != "pelvis"}


def xyz_angles(r: np.ndarray) -> np.ndarray:
    """Body-fixed x-y-z (Cardan) angles [rad] of rotation matrices ``R = Rx(a) Ry(b) Rz(c)``, shape (n, 3).

    For a joint: ``a`` about the parent's x (ab/adduction for the legs), ``b`` about the rotated y (flexion),
    ``c`` about the child's z (axial rotation).
    """
    b = np.arcsin(np.clip(r[:, 0, 2], -1.0, 1.0))
    a = np.arctan2(-r[:, 1, 2], r[:, 2, 2])
    c = np.arctan2(-r[:, 0, 1], r[:, 0, 0])
    return np.stack([a, b, c], axis=-1)


def rotation_from_xyz(ang: np.ndarray) -> np.ndarray:
    """Inverse of :func:`xyz_angles`: ``Rx(a) Ry(b) Rz(c)`` for angles (n, 3) [rad]."""
    a, b, c = (np.asarray(ang, float)[..., i] for i in range(3))
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    r = np.empty(a.shape + (3, 3))
    r[..., 0, 0] = cb * cc
    r[..., 0, 1] = -cb * sc
    r[..., 0, 2] = sb
    r[..., 1, 0] = ca * sc + sa * sb * cc
    r[..., 1, 1] = ca * cc - sa * sb * sc
    r[..., 1, 2] = -sa * cb
    r[..., 2, 0] = sa * sc - ca * sb * cc
    r[..., 2, 1] = sa * cc + ca * sb * sc
    r[..., 2, 2] = ca * cb
    return r
