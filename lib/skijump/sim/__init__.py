"""The ski-jump simulator (skijump paper §4.2, extended): ``contact`` (the path along the profile),
``motion`` (in-run, take-off push, flight, landing), ``attitude`` (body and arm), ``simulate`` (sensors)."""
