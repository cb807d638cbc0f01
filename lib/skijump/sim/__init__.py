"""The ski-jump simulator (skijump paper §4.2, extended): ``contact`` (the path along the profile),
``motion`` (in-run, take-off push, flight, landing), ``attitude`` (body and arm), ``sensors`` and ``full``
(the hardware as it is, issue 39), ``simulate`` (the command's entry; the paper's sensor models too).

It never imports the smoother or its model (``tests/test_layout.py``): the hill file is venue data."""

#: UTC time of t = 0 of a simulated jump unless told otherwise (``SkiJumpConfig.start``); here so that
#: the command's help can show it without importing the simulator.
DEFAULT_START = "2026-01-05T13:00:00Z"

#: Names of the full physics' model-mismatch variants (``sensors.VARIANTS``), here for the command's help.
VARIANT_NAMES = (
    "nominal",
    "multipath",
    "latency",
    "synced",
    "lever",
    "scale",
    "misalign",
    "temperature",
    "vibration",
    "magtable",
    "height",
    "boxcar",
)
