"""The athlete's body from several IMUs (any sport): functional calibration, segment orientations, joint
centres and the centre of mass (gates paper "Body model"; Fasel et al. 2017, Front. Physiol. 8:850).

A sport-independent layer beside the core (it imports only ``core``): the gates' ``gate-anchor`` and any
other sport read its output columns.  Entry points (imported lazily); lengths in m, masses in kg, angles in
rad:

* :func:`body_model_table` -- a session with the sensors of the seven segments -> segment orientations,
  joint centres [m] and ``com_rel_*`` [m] relative to the lumbar joint centre;
* :func:`body_params` -- de Leva's (1996) segments scaled by height [m] and mass [kg];
* :func:`write_opensense` -- the segment orientations as an OpenSim OpenSense orientations file (.sto).

Modules: ``anthropometry`` (de Leva), ``calibration`` (static upright + squats), ``orientation``
(strap-down, drift corrections), ``model`` (joint centres, CoM, joint angles), ``pipeline``, ``opensense``.
"""

from sportfusion.core.exports import lazy_exports

_EXPORTS = {
    "BodyModelParams": "sportfusion.body.pipeline",
    "body_model_table": "sportfusion.body.pipeline",
    "body_params": "sportfusion.body.anthropometry",
    "write_opensense": "sportfusion.body.opensense",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
