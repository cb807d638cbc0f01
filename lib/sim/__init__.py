"""Simulation toolkit that knows no sport: smooth signals (``smooth``) and raw-file writers (``rawfiles``:
phyphox ZIP, NMEA) for the sports' simulators, which live in each sport package (``<sport>.sim``)."""
