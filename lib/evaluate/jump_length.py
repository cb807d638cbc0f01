"""Jump lengths against the video reference, in the layout of the ski-jumping paper's Table 7.

``dL = L_TR - L_VR`` [m] per jump (estimate from ``jump-metrics`` minus the video reading), its RMS and the
RMS upper bound with the video's reading accuracy (0.5 m, Appendix B); jumps are paired by their number
when both tables have one, else in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.evaluate.truth import PAPER_TABLE7_RMS, PAPER_TABLE7_RMS_UB, _json_ready

#: Worst-case error of the paper's manual video reading of the jump length [m] (Appendix B).
PAPER_READING_ACCURACY = 0.5


@dataclass
class JumpLengthComparison:
    """Jump lengths of an estimate against a reference, jump by jump (skijump Table 7).

    Attributes
    ----------
    labels : list of str
        One label per jump (``jump 1``.. or the ``jump`` numbers both tables share).
    estimate : ndarray
        ``L_TR``, jump length of the estimate (e.g. jump-metrics) [m].
    reference : ndarray
        ``L_VR``, jump length of the reference (e.g. video-jumplength) [m].
    reading_accuracy : float
        Worst-case error of the reference [m] used for the upper bound.
    """

    labels: list[str]
    estimate: np.ndarray
    reference: np.ndarray
    reading_accuracy: float

    @property
    def error(self) -> np.ndarray:
        """``dL = L_TR - L_VR`` per jump [m] (NaN where a side has no length)."""
        return self.estimate - self.reference

    @property
    def n(self) -> int:
        """Jumps with a length on both sides."""
        return int(np.sum(np.isfinite(self.error)))

    @property
    def rms(self) -> float:
        """``sqrt(mean(dL^2))`` over the jumps with both lengths [m] (skijump §4.4)."""
        e = self.error[np.isfinite(self.error)]
        return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")

    @property
    def rms_upper_bound(self) -> float:
        """``sqrt(mean((|dL| + u)^2))``, ``u`` the reading accuracy [m] (skijump §4.4)."""
        e = self.error[np.isfinite(self.error)]
        return float(np.sqrt(np.mean((np.abs(e) + self.reading_accuracy) ** 2))) if e.size else float("nan")

    @property
    def mean(self) -> float:
        """Mean error [m]."""
        e = self.error[np.isfinite(self.error)]
        return float(np.mean(e)) if e.size else float("nan")

    @property
    def max(self) -> float:
        """Largest absolute error [m]."""
        e = self.error[np.isfinite(self.error)]
        return float(np.max(np.abs(e))) if e.size else float("nan")


def _jump_numbers(table: pa.Table) -> np.ndarray | None:
    if "jump" not in table.column_names:
        return None
    v = table.column("jump").to_numpy(zero_copy_only=False)
    try:
        nums = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        return None
    return nums if np.all(np.isfinite(nums)) and np.all(nums == np.round(nums)) else None


def compare_jump_lengths(
    est: pa.Table, ref: pa.Table, reading_accuracy: float = PAPER_READING_ACCURACY
) -> JumpLengthComparison:
    """Pair the jumps of two ``jumps`` tables and compare their ``jump_length`` (skijump §4.4, Table 7).

    Jumps are paired by a ``jump`` number column when both tables have one
    (every number of the estimate must be in the reference), otherwise row by
    row, which needs the same number of rows.

    Parameters
    ----------
    est : pyarrow.Table
        Estimate, one row per jump, ``jump_length`` [m] (``L_TR``, e.g. jump-metrics).
    ref : pyarrow.Table
        Reference, one row per jump, ``jump_length`` [m] (``L_VR``, e.g. video-jumplength).
    reading_accuracy : float
        Worst-case error of the reference [m] for the upper bound (the paper: 0.5 m).

    Raises
    ------
    InputError
        A table without ``jump_length`` or without rows, jumps that cannot be paired,
        a negative reading accuracy.
    """
    schema.require_columns(est, ["jump_length"], "comparing jump lengths (the estimate, e.g. jump-metrics output)")
    schema.require_columns(ref, ["jump_length"], "comparing jump lengths (the reference, e.g. video-jumplength output)")
    if not (np.isfinite(reading_accuracy) and reading_accuracy >= 0):
        raise InputError(f"reading accuracy {reading_accuracy} m; expected a finite length >= 0 m")
    if est.num_rows == 0 or ref.num_rows == 0:
        which = "estimate" if est.num_rows == 0 else "reference"
        raise InputError(f"the {which} jumps table has no rows; expected one row per jump")
    l_est, l_ref = schema.floats(est, "jump_length"), schema.floats(ref, "jump_length")
    n_est, n_ref = _jump_numbers(est), _jump_numbers(ref)
    if n_est is not None and n_ref is not None:
        if len(set(n_ref.tolist())) != n_ref.size:
            raise InputError("the reference has repeated jump numbers; expected one row per jump")
        where = {float(v): i for i, v in enumerate(n_ref)}
        missing = [int(v) for v in n_est if float(v) not in where]
        if missing:
            raise InputError(
                f"jump(s) {', '.join(map(str, missing))} of the estimate are not in the reference; "
                f"expected the same jump numbers"
            )
        idx = np.array([where[float(v)] for v in n_est], int)
        return JumpLengthComparison([f"jump {int(v)}" for v in n_est], l_est, l_ref[idx], float(reading_accuracy))
    if est.num_rows != ref.num_rows:
        raise InputError(
            f"the estimate has {est.num_rows} jump(s), the reference {ref.num_rows}; expected the same jumps "
            f"in the same order (or a 'jump' number column in both)"
        )
    labels = [f"jump {k + 1}" for k in range(est.num_rows)]
    return JumpLengthComparison(labels, l_est, l_ref, float(reading_accuracy))


def jump_length_table(cmp: JumpLengthComparison) -> pa.Table:
    """The comparison as a ``summary`` table in Table 7's layout.

    One row per jump (``phase`` = its label, ``stat`` = ``error``) with
    ``jump_length`` (``L_TR``), ``ref_jump_length`` (``L_VR``) and
    ``jump_length_error`` (``dL``) [m]; then ``phase`` = ``all`` rows with
    ``stat`` = ``rms``, ``rms_upper_bound``, ``mean``, ``max`` holding that
    statistic of ``dL`` in ``jump_length_error`` and the jumps behind it in ``samples``.
    """
    stats = {"rms": cmp.rms, "rms_upper_bound": cmp.rms_upper_bound, "mean": cmp.mean, "max": cmp.max}
    n, k = len(cmp.labels), len(stats)
    nan = np.full(k, np.nan)
    return pa.table(
        {
            "phase": pa.array(cmp.labels + ["all"] * k, pa.string()),
            "stat": pa.array(["error"] * n + list(stats), pa.string()),
            "samples": pa.array([1] * n + [cmp.n] * k, pa.int64()),
            "jump_length": schema.to_arrow("jump_length", np.r_[cmp.estimate, nan]),
            "ref_jump_length": schema.to_arrow("ref_jump_length", np.r_[cmp.reference, nan]),
            "jump_length_error": schema.to_arrow("jump_length_error", np.r_[cmp.error, list(stats.values())]),
        }
    )


def jump_length_meta(cmp: JumpLengthComparison) -> dict[str, Any]:
    """The comparison as JSON-ready metadata (key ``evaluation``; missing values are null)."""
    return _json_ready(
        {
            "jump_lengths": [
                {"jump": lab, "estimate": float(a), "reference": float(b), "error": float(a - b)}
                for lab, a, b in zip(cmp.labels, cmp.estimate, cmp.reference, strict=True)
            ],
            "rms": cmp.rms,
            "rms_upper_bound": cmp.rms_upper_bound,
            "mean": cmp.mean,
            "max": cmp.max,
            "reading_accuracy": cmp.reading_accuracy,
            "paper": {"rms": PAPER_TABLE7_RMS, "rms_upper_bound": PAPER_TABLE7_RMS_UB},
            "units": "m",
        }
    )


def format_jump_lengths(cmp: JumpLengthComparison, title: str = "") -> str:
    """Table 7 of the ski-jump paper: L_TR, L_VR and dL per jump, RMS and its upper bound beside the paper's."""
    lines = [title] if title else []
    head = f"{'jump':<10}{'L_TR [m]':>10}{'L_VR [m]':>10}{'dL [m]':>9}"
    lines += [head, "-" * len(head)]

    def f(v: float, spec: str) -> str:
        return format(v, spec) if np.isfinite(v) else f"{'-':>{spec.split('.')[0].lstrip('+')}}"

    for lab, a, b in zip(cmp.labels, cmp.estimate, cmp.reference, strict=True):
        lines.append(f"{lab:<10}{f(a, '10.2f')}{f(b, '10.2f')}{f(a - b, '+9.2f')}")
    u = cmp.reading_accuracy
    lines.append("-" * len(head))
    lines.append(f"RMS of dL over {cmp.n} jump(s): {f(cmp.rms, '.2f')} m   (paper, 5 jumps: {PAPER_TABLE7_RMS:.1f} m)")
    lines.append(
        f"upper bound with {u:.2f} m reading error, sqrt(mean((|dL| + {u:.2f})^2)): {f(cmp.rms_upper_bound, '.2f')} m"
        f"   (paper: {PAPER_TABLE7_RMS_UB:.1f} m)"
    )
    lines.append(f"mean dL {f(cmp.mean, '+.2f')} m, max |dL| {f(cmp.max, '.2f')} m")
    return "\n".join(lines) + "\n"
