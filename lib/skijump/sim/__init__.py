"""The ski-jump simulator (skijump paper §4.2, extended): ``contact`` (the path along the profile),
``motion`` (in-run, take-off push, flight, landing), ``attitude`` (body and arm), ``simulate`` (sensors)."""

#: UTC time of t = 0 of a simulated jump unless told otherwise (``SkiJumpConfig.start``); here so that
#: the command's help can show it without importing the simulator.
DEFAULT_START = "2026-01-05T13:00:00Z"
