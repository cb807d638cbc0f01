"""The centre of mass against the truth, as the gates paper's Tables 1 and 2, and the relative CoM as Fasel
et al. (2017).

The true CoM is low-pass filtered as the paper filtered its reference and estimate alike (2nd-order
Butterworth, 5 Hz, zero phase: :func:`reference_com`).

* Table 1: per run, accuracy (mean) and precision (standard deviation) of the CoM position error (3-D norm,
  and along the local skiing frame of the paper's Fig 4: x along the true CoM velocity, z = x cross gravity,
  y = z cross x) and of the speed error (difference of the speed norms, and the velocity error along the
  same axes), over the samples where the true speed exceeds 1 m/s.
* Table 2: per turn, the figures of the estimate (gate-anchor's ``turns``) and of the truth (the same
  definitions on the true CoM, distances to the surveyed gate); Bland-Altman bias and 95 % limits of
  agreement (bias +- 1.96 sd).  Two ways: as the paper compared them -- its reference CoM came from the
  GNSS antenna plus the same inertial body model, so both systems had the same turn switches, and the
  figures differ by the CoM trajectory only -- the truth taken at the estimate's switch times; and against
  the truth's own switches (the true ankles equidistant from the true CoM, Fasel et al. 2016b), which adds
  the body model's switch timing (~20 ms, ~0.5 m along the track at 23 m/s).
* Relative CoM: ``com_rel_*`` (body-model) against ``true_com_rel_*``: mean and sd of the 3-D error [mm].
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema

#: The paper's Table 1 (all gates, GS): accuracy (sd), precision (sd); rows total, x, y, z.
PAPER_T1 = {
    "position [m]": [((0.24, 0.09), (0.09, 0.09)), ((0.01, 0.10), (0.14, 0.03)), ((0.02, 0.13), (0.10, 0.02)),
                     ((0.01, 0.10), (0.07, 0.04))],
    "speed [m/s]": [((0.00, 0.02), (0.18, 0.02)), ((-0.01, 0.01), (0.30, 0.04)), ((0.00, 0.01), (0.20, 0.03)),
                    ((0.00, 0.00), (0.21, 0.08))],
}  # fmt: skip
#: The paper's Table 2: error mean and upper LoA (the text keeps the abstract's LoAs for speeds and the length).
PAPER_T2 = {"v_in": (0.08, 0.33), "v_out": (-0.01, 0.17), "d_in": (0.02, 0.32), "d_out": (0.02, 0.30),
            "d_cross": (0.05, 0.28), "length": (None, 0.16)}  # fmt: skip
FASEL_2017_MM = (25.7, 6.7)
FIGURES = ("v_in", "v_out", "d_in", "d_out", "d_cross", "length")


def has_com(est: pa.Table, truth: pa.Table) -> bool:
    return "com_x" in est.column_names and "true_com_x" in truth.column_names


def _xyz(table: pa.Table, prefix: str) -> np.ndarray:
    return schema.float_columns(table, [f"{prefix}{a}" for a in "xyz"])


def _at(t_src: np.ndarray, x: np.ndarray, t: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x).all(axis=1)
    return np.column_stack([np.interp(t, t_src[ok], x[ok, j]) for j in range(x.shape[1])])


def reference_com(truth: pa.Table, cutoff: float = 5.0) -> tuple[np.ndarray, np.ndarray]:
    """The true CoM [m] and its velocity [m/s] low-pass filtered as the paper filtered its reference and its
    estimate alike (2nd-order Butterworth, ``cutoff`` Hz, zero phase), on the truth's rows."""
    from scipy.signal import butter, filtfilt

    tt = schema.floats(truth, "t")
    com, vcom = _xyz(truth, "true_com_"), _xyz(truth, "true_com_v")
    fs = 1.0 / float(np.median(np.diff(tt)))
    ok = np.isfinite(com).all(axis=1) & np.isfinite(vcom).all(axis=1)
    if ok.sum() > 15 and cutoff < 0.45 * fs:
        b, a = butter(2, cutoff / (fs / 2))
        com, vcom = com.copy(), vcom.copy()
        com[ok] = filtfilt(b, a, com[ok], axis=0)
        vcom[ok] = filtfilt(b, a, vcom[ok], axis=0)
    return com, vcom


def table1(est: pa.Table, truth: pa.Table) -> dict[str, Any]:
    """Accuracy and precision of the CoM position [m] and speed [m/s] (module text)."""
    t = schema.floats(est, "t")
    tt = schema.floats(truth, "t")
    p, v = _xyz(est, "com_"), _xyz(est, "com_v")
    rc, rv = reference_com(truth)
    tp, tv = _at(tt, rc, t), _at(tt, rv, t)
    ok = np.isfinite(p).all(axis=1) & np.isfinite(v).all(axis=1) & (np.linalg.norm(tv, axis=1) > 1.0)
    p, v, tp, tv = p[ok], v[ok], tp[ok], tv[ok]
    x = tv / np.linalg.norm(tv, axis=1, keepdims=True)
    z = np.cross(x, np.array([0.0, 0.0, 1.0]))
    z /= np.maximum(np.linalg.norm(z, axis=1, keepdims=True), 1e-9)
    y = np.cross(z, x)
    d, dv = p - tp, v - tv
    pos = [np.linalg.norm(d, axis=1)] + [np.sum(d * a, axis=1) for a in (x, y, z)]
    spd = [np.linalg.norm(v, axis=1) - np.linalg.norm(tv, axis=1)] + [np.sum(dv * a, axis=1) for a in (x, y, z)]
    return {
        "samples": int(ok.sum()),
        "position [m]": [(float(e.mean()), float(e.std())) for e in pos],
        "speed [m/s]": [(float(e.mean()), float(e.std())) for e in spd],
    }


def _switch(t: np.ndarray, sig: np.ndarray, a: float, b: float) -> float | None:
    w = np.flatnonzero((t > a) & (t < b))
    if w.size < 3:
        return None
    s = np.sign(sig[w])
    ch = np.flatnonzero(s[1:] != s[:-1])
    if ch.size == 0:
        return None
    j = ch[np.argmin(np.abs(t[w[ch]] - 0.5 * (a + b)))]
    i0, i1 = w[j], w[j + 1]
    f = sig[i0] / (sig[i0] - sig[i1]) if sig[i0] != sig[i1] else 0.5
    return float(t[i0] + f * (t[i1] - t[i0]))


def table2(est_meta: dict[str, Any], truth: pa.Table, shared_switches: bool = True) -> dict[str, Any]:
    """Bland-Altman bias and 95 % limits of agreement of the per-turn figures (module text): the truth at
    the estimate's switch times (``shared_switches``, the paper's comparison) or at its own."""
    turns = (est_meta.get("gate_anchor") or {}).get("turns") or []
    tt = schema.floats(truth, "t")
    com, vcom = reference_com(truth)
    rel = _xyz(truth, "true_com_rel_")
    sig = np.linalg.norm(_xyz(truth, "true_ankle_l_rel_") - rel, axis=1) - np.linalg.norm(
        _xyz(truth, "true_ankle_r_rel_") - rel, axis=1
    )
    ev = truth.column("true_event").to_pylist() if "true_event" in truth.column_names else []
    gates = truth.column("true_gate").to_pylist() if "true_gate" in truth.column_names else []
    tg = {
        int(g): float(tt[i]) for i, (e, g) in enumerate(zip(ev, gates, strict=False)) if e == "gate" and g is not None
    }
    err: dict[str, list[float]] = {k: [] for k in FIGURES}
    for tr in turns:
        g = int(tr["gate"])
        if not {g - 1, g, g + 1} <= set(tg) or "gate_xyz" not in tr:
            continue
        if shared_switches:
            t_in, t_out = float(tr["t_in"]), float(tr["t_out"])
        else:
            t_in, t_out = _switch(tt, sig, tg[g - 1], tg[g]), _switch(tt, sig, tg[g], tg[g + 1])
        if t_in is None or t_out is None:
            continue
        gp = np.asarray(tr["gate_xyz"], float)
        pi, po, pc = (_at(tt, com, np.array([x]))[0] for x in (t_in, t_out, tg[g]))
        seg = (tt > t_in) & (tt < t_out)
        path = np.vstack([pi, com[seg], po])
        true = {
            "v_in": float(np.linalg.norm(_at(tt, vcom, np.array([t_in]))[0])),
            "v_out": float(np.linalg.norm(_at(tt, vcom, np.array([t_out]))[0])),
            "d_in": float(np.linalg.norm(pi - gp)),
            "d_out": float(np.linalg.norm(po - gp)),
            "d_cross": float(np.linalg.norm(pc - gp)),
            "length": float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))),
        }
        for k in FIGURES:
            err[k].append(float(tr[k]) - true[k])
    out: dict[str, Any] = {"turns": len(err["v_in"]), "switches": "shared" if shared_switches else "true"}
    for k, e in err.items():
        a = np.asarray(e)
        out[k] = (
            {"bias": float(a.mean()), "loa": [float(a.mean() - 1.96 * a.std()), float(a.mean() + 1.96 * a.std())]}
            if a.size
            else None
        )
    return out


def segment_lengths(est: pa.Table, truth: pa.Table, filtered: bool = True) -> dict[str, Any] | None:
    """CoM path length [m] between consecutive true gate crossings, estimate minus truth (``filtered``: the
    reference of :func:`reference_com`, else the raw true CoM): bias and 95 % limits of agreement (the
    paper's turn length l_tot runs from switch to switch; this needs no switches)."""
    if "true_event" not in truth.column_names:
        return None
    t, tt = schema.floats(est, "t"), schema.floats(truth, "t")
    com, tcom = _xyz(est, "com_"), reference_com(truth)[0] if filtered else _xyz(truth, "true_com_")
    ev = truth.column("true_event").to_pylist()
    tg = np.array([tt[i] for i, e in enumerate(ev) if e == "gate"])

    def length(tq: np.ndarray, x: np.ndarray, a: float, c: float) -> float:
        """Path length of ``x`` from time ``a`` to ``c``: the ends interpolated, the samples between."""
        inner = (tq > a) & (tq < c)
        path = np.vstack([_at(tq, x, np.array([a])), x[inner], _at(tq, x, np.array([c]))])
        return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))

    ok = np.isfinite(com).all(axis=1)
    d = []
    for a, c in zip(tg[:-1], tg[1:], strict=True):
        if ok[(t >= a) & (t <= c)].all() and t[ok][0] <= a and t[ok][-1] >= c:
            d.append(length(t[ok], com[ok], a, c) - length(tt, tcom, a, c))
    if not d:
        return None
    x = np.asarray(d)
    return {"segments": x.tolist(), "bias": float(x.mean()), "loa": [float(x.mean() - 1.96 * x.std()),
            float(x.mean() + 1.96 * x.std())]}  # fmt: skip


def relative_com(est: pa.Table, truth: pa.Table) -> dict[str, float] | None:
    """Error of ``com_rel_*`` against ``true_com_rel_*`` [mm]: mean and sd of the 3-D norm."""
    if "com_rel_x" not in est.column_names or "true_com_rel_x" not in truth.column_names:
        return None
    t, tt = schema.floats(est, "t"), schema.floats(truth, "t")
    r = _xyz(est, "com_rel_")
    ok = np.isfinite(r).all(axis=1)
    e = np.linalg.norm(r[ok] - _at(tt, _xyz(truth, "true_com_rel_"), t[ok]), axis=1) * 1000.0
    return {"mean_mm": float(e.mean()), "sd_mm": float(e.std())}


def evaluate_com(est: pa.Table, est_meta: dict[str, Any], truth: pa.Table) -> dict[str, Any]:
    """Tables 1 and 2 and the relative CoM (module text)."""
    return {
        "table1": table1(est, truth),
        "table2": table2(est_meta, truth),
        "table2_true_switches": table2(est_meta, truth, shared_switches=False),
        "segments": segment_lengths(est, truth),
        "relative": relative_com(est, truth),
    }


def format_com(res: dict[str, Any]) -> str:
    """Tables 1 and 2 beside the paper's numbers, and the relative CoM beside Fasel et al. (2017)."""
    t1 = res["table1"]
    lines = [
        f"CoM vs truth, gates paper Table 1 layout ({t1['samples']} samples with true speed > 1 m/s): "
        "accuracy (mean) and precision (sd) of the error; axes of the local skiing frame (Fig 4)",
        f"{'':22s} {'accuracy':>9s} {'paper':>13s} {'precision':>10s} {'paper':>13s}",
    ]
    for q in ("position [m]", "speed [m/s]"):
        for i, ax in enumerate(("total", "x", "y", "z")):
            (a, s), ((pa_, pas), (pp, pps)) = t1[q][i], PAPER_T1[q][i]
            lines.append(f"{q + ' ' + ax:22s} {a:9.3f} {pa_:6.2f} ({pas:.2f}) {s:10.3f} {pp:6.2f} ({pps:.2f})")
    t2, t2t = res["table2"], res.get("table2_true_switches") or {}
    lines += [
        "",
        f"turn figures, gates paper Table 2 layout ({t2['turns']} turns): Bland-Altman bias, 95 % LoA; the truth at "
        "the estimate's turn switches (as the paper, whose reference shared the body model) and at its own",
    ]
    lines.append(
        f"{'':12s} {'bias':>7s} {'LoA (shared switches)':>22s} {'LoA (true switches)':>22s} | paper bias, upper LoA"
    )
    for k in FIGURES:
        pm, pu = PAPER_T2[k]
        v, w = t2.get(k), t2t.get(k)
        ours = f"{v['bias']:7.3f} [{v['loa'][0]:8.3f}, {v['loa'][1]:8.3f}]" if v else f"{'-':>7s} {'-':>22s}"
        ours += f" [{w['loa'][0]:8.3f}, {w['loa'][1]:8.3f}]" if w else f" {'-':>22s}"
        unit = "m/s" if k.startswith("v_") else "m"
        lines.append(f"{k + ' [' + unit + ']':12s} {ours} | {'-' if pm is None else f'{pm:.2f}'}, {pu:.2f}")
    sg = res.get("segments")
    if sg:
        lines.append(
            f"CoM path length per gate-to-gate segment ({len(sg['segments'])}): bias {sg['bias']:.3f} m, LoA "
            f"[{sg['loa'][0]:.3f}, {sg['loa'][1]:.3f}] m (paper, turn length l_tot: -0.06 to 0.16 m)"
        )
    rel = res.get("relative")
    if rel:
        lines += [
            "",
            f"relative CoM (body-model com_rel_* vs truth): {rel['mean_mm']:.1f} +- {rel['sd_mm']:.1f} mm "
            f"(Fasel et al. 2017 against motion capture: {FASEL_2017_MM[0]} +- {FASEL_2017_MM[1]} mm)",
        ]
    return "\n".join(lines) + "\n"
