"""rts-smooth's predicted magnetometer (eq 50; the paper's Figure 12) against the simulator's truth."""

from __future__ import annotations

import numpy as np

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.smoother import rts_smooth_table

FIX = "fixtures/skijump/"


def test_predicted_magnetometer_matches_the_noise_free_measurement():
    tab, meta = sfio.read_table(FIX + "session.parquet")
    truth, tmeta = sfio.read_table(FIX + "truth.parquet", kind="truth")
    times = tmeta["skijump"]["times"]
    out, _, _ = rts_smooth_table(
        tab, meta, load_hill("oberstdorf_hs106"), takeoff=[times["takeoff"]], touchdown=[times["touchdown"]]
    )
    for a in "xyz":
        pred = schema.floats(out, f"mag_pred_{a}")
        meas = schema.floats(out, f"mag_{a}")
        # what the sensor saw without its white noise: the true body-frame field, scaled and biased (eq 50)
        clean = (1.0 + schema.floats(truth, f"true_scale_mag_{a}")) * schema.floats(truth, f"true_mag_{a}")
        clean += schema.floats(truth, f"true_bias_mag_{a}")
        ok = np.isfinite(meas)
        # the fixture's magnetometer (full physics): 0.4 uT of white noise, a full soft-iron matrix (eq 50 has its
        # diagonal), steel under the take-off table.  The prediction follows the measurement to its noise and
        # the unmodelled cross terms (measured 0.51 / 0.61 / 0.51 uT) ...
        assert 0.3 < np.sqrt(np.mean((meas[ok] - pred[ok]) ** 2)) < 1.0, a
        # ... and, away from the table, the noise-free field of eq 50's model (measured 0.43 / 0.39 / 0.28 uT)
        far = ok & ((schema.floats(truth, "true_x") < -20.0) | (schema.floats(truth, "t") > times["touchdown"] + 0.5))
        assert np.sqrt(np.mean((clean[far] - pred[far]) ** 2)) < 0.8, a
