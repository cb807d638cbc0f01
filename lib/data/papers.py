"""The four papers the suite implements, cited in full (README, docs and each tool's ``--help``).

Keys are the short names used in docstrings and help texts (``skijump §3``, ``gates paper``, ...).
"""

from __future__ import annotations

__all__ = ["PAPERS", "citation"]

#: short name -> full citation (authors, year, title, venue, DOI or address).
PAPERS: dict[str, str] = {
    "skijump": (
        "Fang X, Grüter B, Piprek P, Bessone V, Petrat J, Holzapfel F (2020). Ski Jumping Trajectory "
        "Reconstruction Using Wearable Sensors via Extended Rauch-Tung-Striebel Smoother with State "
        "Constraints. Sensors 20(7):1995. doi:10.3390/s20071995"
    ),
    "skiracing-splines": (
        "Skaloud J, Limpach P (2003). Synergy of CP-DGPS, Accelerometry and Magnetic Sensors for Precise "
        "Trajectory in Ski Racing. Proceedings of ION GPS/GNSS 2003, Institute of Navigation, Portland, OR "
        "(no DOI)"
    ),
    "gates": (
        "Fasel B, Gilgien M, Spörri J, Aminian K (2018). A New Training Assessment Method for Alpine Ski "
        "Racing: Estimating Center of Mass Trajectory by Fusing Inertial Sensors With Periodically Available "
        "Position Anchor Points. Frontiers in Physiology 9:1203. doi:10.3389/fphys.2018.01203"
    ),
    "climbing": (
        "Koller TL, Laue T, Frese U (2022). Event-Domain Knowledge in Inertial Sensor Based State Estimation "
        "of Human Motion. EasyChair Preprint, 28 March 2022. https://easychair.org/publications/preprint/rhMf"
    ),
}


def citation(key: str) -> str:
    """The full citation of a paper by its short name (``skijump``, ``skiracing-splines``, ``gates``, ``climbing``)."""
    return PAPERS[key]
