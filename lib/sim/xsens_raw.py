"""Write a simulated multi-IMU session as Xsens MT Manager text exports (one file per sensor) with OpenSim
OpenSense's mapping file, the raw files ``ingest FOLDER`` reads (:mod:`sportfusion.ingest.xsensdir`).

Each sensor's file ``<trial_prefix><_ID>.txt`` has MT Manager's short header (``// Update Rate: R Hz``) and
tab-separated ``PacketCounter SampleTimeFine Acc_X.. Gyr_X.. [Mag_X..]`` rows: specific force [m/s^2],
angular rate [rad/s], magnetic field normalised by ``mag_norm`` [uT] (MT Manager's unit: 1 = the field at
calibration).  The counters are shared by all sensors (a wireless-synchronised recording) and start at an
arbitrary value; ``myIMUMappings.xml`` names each sensor's segment as OpenSense does (``<name_in_model>``
``pelvis_imu``...).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa

SEP = "__"


def _ids(segments: list[str], seed: int) -> dict[str, str]:
    rng = np.random.default_rng(seed + 31)
    base = int(rng.integers(0x00B40000, 0x00B4F000))
    return {seg: f"{base + 7 * i:08X}" for i, seg in enumerate(segments)}


def write_xsens_folder(
    session: pa.Table,
    folder: str | Path,
    segments: list[str],
    rate: float,
    mag_norm: float = 1.0,
    seed: int = 0,
    trial_prefix: str = "MT_SIM_001-000",
) -> dict[str, str]:
    """Write one export per segment's sensor (columns ``acc_*`` for the pelvis, ``<seg>__acc_*`` for the others)
    and the mapping file into ``folder``; returns segment -> sensor id.  Rows where the sensor has no sample are
    left out of its file."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    t = session.column("t").to_numpy()
    ids = _ids(segments, seed)
    rng = np.random.default_rng(seed + 37)
    stf0 = int(rng.integers(1_000_000, 2_000_000_000))
    pc0 = int(rng.integers(0, 65536))
    for seg in segments:

        def col(name: str, seg: str = seg) -> np.ndarray | None:
            n = name if seg == "pelvis" else f"{seg}{SEP}{name}"
            if n not in session.column_names:
                return None
            return np.asarray(session.column(n).to_numpy(zero_copy_only=False), dtype=float)

        acc = [col(f"acc_{a}") for a in "xyz"]
        gyr = [col(f"gyr_{a}") for a in "xyz"]
        mag = [col(f"mag_{a}") for a in "xyz"]
        if any(v is None for v in acc + gyr):
            raise ValueError(f"no acc_*/gyr_* columns for {seg}")
        a = np.column_stack(acc)
        g = np.column_stack(gyr)
        ok = np.isfinite(a).all(axis=1) & np.isfinite(g).all(axis=1)
        cols = ["PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z"]
        m = None
        if all(v is not None for v in mag):
            m = np.column_stack(mag) / mag_norm
            ok &= np.isfinite(m).all(axis=1)
            cols += ["Mag_X", "Mag_Y", "Mag_Z"]
        k = np.flatnonzero(ok)
        pc = (pc0 + np.rint(t[k] * rate).astype(np.int64)) % 65536
        stf = (stf0 + np.rint(t[k] * 1e4).astype(np.int64)) % (2**32)
        lines = [
            "// Start Time: Unknown",
            f"// Update Rate: {rate:.1f}Hz",
            "// Filter Profile: human (46.1)",
            "// Option Flags: AHS Disabled ICC Disabled ",
            "// Firmware Version: 4.0.2",
            "\t".join(cols),
        ]
        for j, i in enumerate(k):
            vals = [f"{pc[j]:05d}", f"{stf[j]}"] + [f"{v:.6f}" for v in a[i]] + [f"{v:.6f}" for v in g[i]]
            if m is not None:
                vals += [f"{v:.6f}" for v in m[i]]
            lines.append("\t".join(vals))
        (out / f"{trial_prefix}_{ids[seg]}.txt").write_text("\n".join(lines) + "\n")
    sensors = "\n".join(
        f'\t\t\t<ExperimentalSensor name="_{ids[s]}">\n\t\t\t\t<name_in_model>{s}_imu</name_in_model>\n'
        "\t\t\t</ExperimentalSensor>"
        for s in segments
    )
    (out / "myIMUMappings.xml").write_text(
        '<?xml version="1.0" encoding="UTF-8" ?>\n<OpenSimDocument Version="40000">\n\t<XsensDataReaderSettings>\n'
        f"\t\t<trial_prefix>{trial_prefix}</trial_prefix>\n\t\t<ExperimentalSensors>\n{sensors}\n"
        "\t\t</ExperimentalSensors>\n\t</XsensDataReaderSettings>\n</OpenSimDocument>\n"
    )
    return ids
