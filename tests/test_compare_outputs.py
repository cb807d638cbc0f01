"""bench/compare_outputs.py: the refactoring check finds a changed number and accepts last-bit noise."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pyarrow as pa

from sportfusion.core import io as sfio

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("compare_outputs", ROOT / "bench" / "compare_outputs.py")
co = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
spec.loader.exec_module(co)  # type: ignore[union-attr]


def _tree(root: Path, x: np.ndarray, note: str) -> Path:
    root.mkdir()
    table = pa.table({"t": np.arange(x.size, dtype=float), "x": x})
    sfio.write_table(
        table,
        {
            "version": 1,
            "kind": "session",
            "time": {"epoch_utc": None},
            "rts": {"rms": float(x.sum())},
            "provenance": [],
        },
        root / "s.parquet",
    )
    (root / "summary.txt").write_text(f"{root}: jump length {x.sum():.12f} m, {note}\n")
    return root


def test_identical_within_tolerance_and_a_real_change_is_found(tmp_path: Path) -> None:
    x = np.linspace(0.0, 90.0, 50)
    a = _tree(tmp_path / "a", x, "ok")
    b = _tree(tmp_path / "b", x * (1 + 1e-13), "ok")
    assert co.compare_trees(a, b, rtol=1e-9, atol=1e-9) == []
    c = _tree(tmp_path / "c", x + np.r_[np.zeros(49), 1e-3], "ok")
    diffs = co.compare_trees(a, c, rtol=1e-9, atol=1e-9)
    assert any("x: max difference" in d for d in diffs)
    assert any("summary.txt" in d for d in diffs)
    d = _tree(tmp_path / "d", x, "changed")
    assert co.compare_trees(a, d, rtol=1e-9, atol=1e-9) == ["summary.txt: text differs"]
