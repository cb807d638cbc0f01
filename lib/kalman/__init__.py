"""The smoother core: EKF forward + RTS backward with constraints (skijump paper §3)."""

from sportfusion.kalman.core import (
    CovarianceError,
    Measurement,
    SmootherResult,
    discretize,
    ekf_rts,
    rk4_step,
    symmetrize,
)

__all__ = [
    "CovarianceError",
    "Measurement",
    "SmootherResult",
    "discretize",
    "ekf_rts",
    "rk4_step",
    "symmetrize",
]
