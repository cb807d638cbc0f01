"""Simulation toolkit that knows no sport: smooth signals (``smooth``), raw-file writers (``rawfiles``:
phyphox ZIP, NMEA), recording faults (``faults``), magnetic sources from magnetic charges (``magnetics``:
bar magnets, iron, anomalies) and sensor error models (``sensors``: scale, misalignment, bias, temperature,
quantisation, range, vibration) for the sports' simulators, which live in each sport package
(``<sport>.sim``) and import this toolkit and the core only -- never the estimators they score."""
