"""Segment lengths, masses and centre-of-mass locations: de Leva (1996), scaled by height and mass.

de Leva P. (1996) Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters. J. Biomech. 29:1223-1230,
Table 4: segment lengths of the reference subjects (stature 1741 mm male / 1735 mm female), mass [% of body
mass] and longitudinal CoM location [% of the segment length from the first end point]; the shank is Table 4's
alternative definition from the knee to the ankle joint centre (KJC-AJC: 440.3 / 438.6 mm, CoM 43.95 / 43.52 %),
the trunk its three-part one (upper, middle, lower).  Every number below was checked against two public
transcriptions of Table 4: R. Gurchiek's ``deleva.m`` (github.com/gurchiek/nms-dyn,
general_library/biomx/MusculoskeletalModel/SegmentInertia) and the ``DeLevaTable`` of pyomeca's biorbd
model-creation examples (masses and CoMs of the main segments).

The seven sensed segments of the gates paper (pelvis, torso, head, both thighs and shanks) and the parts
without a sensor, carried by one of them:

==========  ================================  ===========================================================
segment     de Leva segments                  carried parts
==========  ================================  ===========================================================
pelvis      lower trunk (OMPH-MIDH)           --
torso       upper + middle trunk (SUPR-OMPH)  both arms (upper arm, forearm, hand) in a skiing posture
head        head (VERT-MIDG, with the neck)   --
femur_r/l   thigh (HJC-KJC)                   --
tibia_r/l   shank (KJC-AJC)                   the foot in its boot; boots and skis (``equipment``)
==========  ================================  ===========================================================

Geometry (our choices where de Leva gives no landmark; all lengths are fractions of the height ``H``):
the lumbar joint centre (LJC, L5/S1) is the origin of the pelvis and the torso; the hip joint centres lie
0.045 H below it, 0.025 H forward and 0.05 H to each side (an inter-hip distance of 0.1 H, 0.18 m for a 1.80 m
athlete); the navel (OMPH) is 0.0337 H above the LJC (lower trunk length minus the hip depth); the cervical
joint centre (CJC) is at the suprasternale (SUPR), the top of the torso; the neck (SUPR to mid-gonion) is
0.0653 H (stature minus head length minus the SUPR height of the reference male); the arms hang from the
shoulders holding the poles (combined CoM 0.06 H forward of and 0.13 H below the SUPR... see ``ARMS``); the
foot's CoM is 0.04 H forward and 0.025 H below the ankle along the shank (boot locks the ankle).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sportfusion.core.errors import InputError

#: Reference statures of de Leva's Table 4 [mm].
STATURE_MM = {"male": 1741.0, "female": 1735.0}
#: Segment lengths of de Leva's Table 4 [mm]: head VERT-MIDG, upper trunk SUPR-XYPH, middle trunk XYPH-OMPH,
#: lower trunk OMPH-MIDH, thigh HJC-KJC, shank KJC-AJC, foot HEEL-TTIP.
LENGTH_MM = {
    "male": {"head": 203.3, "upper_trunk": 170.7, "mid_trunk": 215.5, "lower_trunk": 145.7, "thigh": 422.2,
             "shank": 440.3, "foot": 258.1},
    "female": {"head": 200.2, "upper_trunk": 142.5, "mid_trunk": 205.3, "lower_trunk": 181.5, "thigh": 368.5,
               "shank": 438.6, "foot": 228.3},
}  # fmt: skip
#: Segment masses of de Leva's Table 4 [% of body mass].
MASS_PCT = {
    "male": {"head": 6.94, "upper_trunk": 15.96, "mid_trunk": 16.33, "lower_trunk": 11.17, "upper_arm": 2.71,
             "forearm": 1.62, "hand": 0.61, "thigh": 14.16, "shank": 4.33, "foot": 1.37},
    "female": {"head": 6.68, "upper_trunk": 15.45, "mid_trunk": 14.65, "lower_trunk": 12.47, "upper_arm": 2.55,
               "forearm": 1.38, "hand": 0.56, "thigh": 14.78, "shank": 4.81, "foot": 1.29},
}  # fmt: skip
#: Longitudinal CoM of de Leva's Table 4 [% of the length from the first end point named above].
COM_PCT = {
    "male": {"head": 59.76, "upper_trunk": 29.99, "mid_trunk": 45.02, "lower_trunk": 61.15, "thigh": 40.95,
             "shank": 43.95, "foot": 44.15},
    "female": {"head": 58.94, "upper_trunk": 20.77, "mid_trunk": 45.12, "lower_trunk": 49.20, "thigh": 36.12,
               "shank": 43.52, "foot": 40.14},
}  # fmt: skip
#: Our geometry (fractions of the height): see the module text.
HIP_DOWN, HIP_FORWARD, HIP_SIDE = 0.045, 0.025, 0.05
NECK = 0.0653
#: Combined CoM of both arms in the torso frame (x forward, y right, z down) relative to the SUPR [H].
ARMS = (0.06, 0.0, 0.13)
#: Foot CoM relative to the ankle in the shank frame [H].
FOOT = (0.04, 0.0, 0.025)
#: Default mass of boots and skis with bindings, both legs together [kg] (2 x 2.0 kg boots, 2 x 4.0 kg skis).
EQUIPMENT_KG = 12.0
#: Ski-snow contact point below the ankle along the shank (gates paper, "Relative anchor") [m].
CONTACT_M = 0.15
#: Human range accepted for --height [m] and --mass [kg].
HEIGHT_RANGE = (1.0, 2.5)
MASS_RANGE = (25.0, 200.0)

SEGMENTS = ("pelvis", "torso", "head", "femur_r", "femur_l", "tibia_r", "tibia_l")
PARENT = {"torso": "pelvis", "head": "torso", "femur_r": "pelvis", "femur_l": "pelvis", "tibia_r": "femur_r",
          "tibia_l": "femur_l"}  # fmt: skip


@dataclass
class BodyParams:
    """The scaled body of one athlete: joints, points and masses in each segment's frame.

    Segment frames: x forward, y right, z down (distal) when standing upright; lengths [m], masses [kg].

    Attributes
    ----------
    joint : dict
        Segment -> position of its proximal joint in its parent's frame (pelvis: the LJC at the origin).
    com : dict
        Segment -> (mass [kg], CoM (3,) [m]) in its own frame, carried parts included.
    points : dict
        Named points (segment, (3,) position in its frame): ``hip_r`` ... ``ankle_l``, ``sternum``, ``head``,
        ``ski_r``, ``ski_l``.
    lengths : dict
        Thigh, shank, trunk (LJC to SUPR), head lengths actually used [m].
    """

    height: float
    mass: float
    sex: str
    equipment: float
    joint: dict[str, np.ndarray] = field(default_factory=dict)
    com: dict[str, tuple[float, np.ndarray]] = field(default_factory=dict)
    points: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)
    lengths: dict[str, float] = field(default_factory=dict)

    @property
    def total_mass(self) -> float:
        """Body plus equipment [kg]."""
        return float(sum(m for m, _ in self.com.values()))


def check_athlete(height: float, mass: float) -> None:
    """Refuse a height [m] or mass [kg] out of the human range (one clear line)."""
    if not (HEIGHT_RANGE[0] <= height <= HEIGHT_RANGE[1]):
        raise InputError(
            f"height {height:g} m is out of the human range {HEIGHT_RANGE[0]:g}-{HEIGHT_RANGE[1]:g} m (give --height in metres)"
        )
    if not (MASS_RANGE[0] <= mass <= MASS_RANGE[1]):
        raise InputError(
            f"mass {mass:g} kg is out of the human range {MASS_RANGE[0]:g}-{MASS_RANGE[1]:g} kg (--mass in kg)"
        )


def body_params(
    height: float,
    mass: float,
    sex: str = "male",
    equipment: float = EQUIPMENT_KG,
    lengths: dict[str, float] | None = None,
    contact: float = CONTACT_M,
) -> BodyParams:
    """de Leva's segments scaled to an athlete (module text).

    Parameters
    ----------
    height : float
        Stature [m].
    mass : float
        Body mass without equipment [kg].
    sex : {"male", "female"}
        Which of de Leva's tables.
    equipment : float
        Boots and skis, both legs [kg], half at each ankle.
    lengths : dict, optional
        Measured lengths [m] replacing the scaled ones: ``thigh`` (hip to knee joint centre), ``shank``
        (knee to ankle), ``trunk`` (LJC to suprasternale), ``head`` (suprasternale to vertex).
    contact : float
        Ski contact point below the ankle along the shank [m].
    """
    check_athlete(height, mass)
    if sex not in STATURE_MM:
        raise InputError(f"sex {sex!r}: expected male or female (de Leva's two tables)")
    if not (0.0 <= equipment <= 60.0):
        raise InputError(f"equipment mass {equipment:g} kg is out of range 0-60 kg")
    H, M = float(height), float(mass)
    f = {k: v / STATURE_MM[sex] for k, v in LENGTH_MM[sex].items()}
    mp = {k: v / 100.0 * M for k, v in MASS_PCT[sex].items()}
    cp = {k: v / 100.0 for k, v in COM_PCT[sex].items()}
    given = dict(lengths or {})
    bad = set(given) - {"thigh", "shank", "trunk", "head"}
    if bad:
        raise InputError(f"unknown measured length(s) {', '.join(sorted(bad))}; expected thigh, shank, trunk, head")
    for k, v in given.items():
        if not (0.05 <= v <= 1.5):
            raise InputError(f"measured {k} length {v:g} m is out of range 0.05-1.5 m")
    L_thigh = given.get("thigh", f["thigh"] * H)
    L_shank = given.get("shank", f["shank"] * H)
    omph = (f["lower_trunk"] - HIP_DOWN) * H
    ut, mt = f["upper_trunk"] * H, f["mid_trunk"] * H
    trunk = given.get("trunk", omph + mt + ut)
    s = trunk / (omph + mt + ut)  # a measured trunk length scales the trunk's parts
    omph, ut, mt = omph * s, ut * s, mt * s
    head_len = f["head"] * H
    neck = NECK * H
    hs = given.get("head", neck + head_len) / (neck + head_len)
    neck, head_len = neck * hs, head_len * hs
    z = np.array([0.0, 0.0, 1.0])
    b = BodyParams(H, M, sex, float(equipment))
    hip = {side: np.array([HIP_FORWARD * H, sgn * HIP_SIDE * H, HIP_DOWN * H]) for side, sgn in (("r", 1), ("l", -1))}
    supr = -(omph + mt + ut) * z
    b.joint = {
        "pelvis": np.zeros(3),
        "torso": np.zeros(3),
        "head": supr,
        "femur_r": hip["r"],
        "femur_l": hip["l"],
        "tibia_r": L_thigh * z,
        "tibia_l": L_thigh * z,
    }
    # pelvis: the lower trunk, from the navel down to the hips
    lt_len = f["lower_trunk"] * H
    pel_com = -omph * z + cp["lower_trunk"] * lt_len * z + np.array([HIP_FORWARD * H / 2, 0, 0])
    # torso: middle trunk (XYPH -> OMPH), upper trunk (SUPR -> XYPH), arms
    xyph = -(omph + mt) * z
    mid_com = xyph + cp["mid_trunk"] * mt * z
    up_com = supr + cp["upper_trunk"] * ut * z
    arms_m = 2 * (mp["upper_arm"] + mp["forearm"] + mp["hand"])
    arms_com = supr + np.array(ARMS) * H
    torso_m = mp["upper_trunk"] + mp["mid_trunk"] + arms_m
    torso_com = (mp["mid_trunk"] * mid_com + mp["upper_trunk"] * up_com + arms_m * arms_com) / torso_m
    vert = -(neck + head_len) * z
    head_com = vert + cp["head"] * head_len * z
    foot = np.array(FOOT) * H + L_shank * z
    ankle = L_shank * z
    eq = equipment / 2.0
    shank_m = mp["shank"] + mp["foot"] + eq
    shank_com = (mp["shank"] * cp["shank"] * L_shank * z + mp["foot"] * foot + eq * ankle) / shank_m
    b.com = {
        "pelvis": (mp["lower_trunk"], pel_com),
        "torso": (torso_m, torso_com),
        "head": (mp["head"], head_com),
        "femur_r": (mp["thigh"], cp["thigh"] * L_thigh * z),
        "femur_l": (mp["thigh"], cp["thigh"] * L_thigh * z),
        "tibia_r": (shank_m, shank_com),
        "tibia_l": (shank_m, shank_com),
    }
    b.points = {
        "hip_r": ("pelvis", hip["r"]),
        "hip_l": ("pelvis", hip["l"]),
        "knee_r": ("femur_r", L_thigh * z),
        "knee_l": ("femur_l", L_thigh * z),
        "ankle_r": ("tibia_r", ankle),
        "ankle_l": ("tibia_l", ankle),
        "ski_r": ("tibia_r", (L_shank + contact) * z),
        "ski_l": ("tibia_l", (L_shank + contact) * z),
        "sternum": ("torso", supr),
        "head": ("head", head_com),
    }
    b.lengths = {"thigh": L_thigh, "shank": L_shank, "trunk": float(trunk), "head": float(neck + head_len)}
    return b
