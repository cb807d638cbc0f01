"""``evaluate --video``: jump lengths of an estimate against a video reading (skijump §4.4, Table 7).

The reference figures are the paper's own Table 7: L_TR and L_VR of five jumps,
RMS of dL = 1.0 m and its upper bound with a 0.5 m reading error = 1.5 m (both
rounded to 0.1 m in the paper).
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.evaluate import compare_jump_lengths, format_jump_lengths, jump_length_table

#: skijump Table 7.
L_TR = [91.6, 85.8, 98.6, 69.5, 86.0]
L_VR = [90.0, 85.0, 97.5, 70.0, 85.5]


def jumps(lengths: list[float], numbers: list[int] | None = None, **extra: list) -> pa.Table:
    cols: dict[str, pa.Array] = {"jump_length": schema.to_arrow("jump_length", np.asarray(lengths, float))}
    if numbers is not None:
        cols["jump"] = pa.array(numbers, pa.int32())
    for k, v in extra.items():
        cols[k] = pa.array(v)
    return pa.table(cols)


def test_paper_table7_figures():
    cmp = compare_jump_lengths(jumps(L_TR), jumps(L_VR))
    np.testing.assert_allclose(cmp.error, [1.6, 0.8, 1.1, -0.5, 0.5], atol=1e-9)
    # the paper prints 1.0 m and 1.5 m, rounded to 0.1 m
    assert round(cmp.rms, 1) == 1.0 and round(cmp.rms_upper_bound, 1) == 1.5
    # exact values by hand: sqrt(4.91 / 5), sqrt(10.66 / 5)
    assert cmp.rms == pytest.approx(np.sqrt(4.91 / 5), abs=1e-12)
    assert cmp.rms_upper_bound == pytest.approx(np.sqrt(10.66 / 5), abs=1e-12)
    assert cmp.mean == pytest.approx(0.7) and cmp.max == pytest.approx(1.6)


def test_upper_bound_grows_with_the_reading_accuracy():
    e = np.array([0.3, -0.2, 0.0])
    cmp = compare_jump_lengths(jumps(list(80 + e)), jumps([80.0] * 3), reading_accuracy=0.0)
    assert cmp.rms_upper_bound == pytest.approx(cmp.rms)
    cmp = compare_jump_lengths(jumps(list(80 + e)), jumps([80.0] * 3), reading_accuracy=1.0)
    assert cmp.rms_upper_bound == pytest.approx(np.sqrt(np.mean((np.abs(e) + 1.0) ** 2)))


def test_pairs_by_jump_number_when_both_have_one():
    est = jumps([70.0, 80.0, 90.0], numbers=[1, 2, 3])
    ref = jumps([90.4, 69.9, 80.2, 100.0], numbers=[3, 1, 2, 4])  # shuffled, one extra jump in the reference
    cmp = compare_jump_lengths(est, ref)
    assert cmp.labels == ["jump 1", "jump 2", "jump 3"]
    np.testing.assert_allclose(cmp.error, [0.1, -0.2, -0.4], atol=1e-9)


def test_missing_length_is_left_out_of_the_statistics():
    cmp = compare_jump_lengths(jumps([70.0, float("nan"), 90.0]), jumps([70.5, 80.0, 89.0]))
    assert cmp.n == 2
    assert cmp.rms == pytest.approx(np.sqrt((0.25 + 1.0) / 2))
    text = format_jump_lengths(cmp)
    assert "over 2 jump(s)" in text


def test_summary_table_layout():
    t = jump_length_table(compare_jump_lengths(jumps(L_TR), jumps(L_VR)))
    rows = t.to_pylist()
    assert [r["phase"] for r in rows[:5]] == [f"jump {k}" for k in range(1, 6)]
    assert rows[0]["jump_length"] == 91.6 and rows[0]["ref_jump_length"] == 90.0
    assert rows[0]["jump_length_error"] == pytest.approx(1.6)
    stats = {r["stat"]: r["jump_length_error"] for r in rows[5:]}
    assert stats["rms"] == pytest.approx(np.sqrt(4.91 / 5)) and stats["rms_upper_bound"] == pytest.approx(
        np.sqrt(10.66 / 5)
    )
    assert all(r["samples"] == 5 for r in rows[5:])


@pytest.mark.parametrize(
    ("est", "ref", "message"),
    [
        (jumps([80.0, 81.0]), jumps([80.0]), "the estimate has 2 jump(s), the reference 1"),
        (jumps([80.0], numbers=[2]), jumps([80.0], numbers=[1]), "jump(s) 2 of the estimate are not in the reference"),
        (pa.table({"x": [1.0]}), jumps([80.0]), "jump_length"),
        (jumps([]), jumps([80.0]), "no rows"),
    ],
)
def test_bad_pairs(est, ref, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        compare_jump_lengths(est, ref)


def _write(table: pa.Table, path) -> None:
    sfio.write_table(table, sfmeta.new_meta("jumps"), path)


def test_cli_text_and_parquet(tmp_path):
    _write(jumps(L_TR), tmp_path / "tr.parquet")
    _write(jumps(L_VR, video=[f"jump{k}.mp4" for k in range(5)]), tmp_path / "vr.parquet")
    r = run_cli(["evaluate", str(tmp_path / "tr.parquet"), "--video", str(tmp_path / "vr.parquet"), "--format", "text"])
    assert r.returncode == 0, r.stderr
    text = r.stdout.decode()
    assert "jump 1         91.60     90.00    +1.60" in text
    assert "0.99 m   (paper, 5 jumps: 1.0 m)" in text and "1.46 m   (paper: 1.5 m)" in text
    out = tmp_path / "s.parquet"
    r = run_cli(
        ["evaluate", "--video", str(tmp_path / "vr.parquet"), "-o", str(out)],
        stdin=(tmp_path / "tr.parquet").read_bytes(),
    )
    assert r.returncode == 0, r.stderr
    table, meta = sfio.read_table(out, kind="summary")
    assert table.num_rows == 9
    ev = meta["evaluation"]
    assert ev["rms"] == pytest.approx(np.sqrt(4.91 / 5)) and ev["reading_accuracy"] == 0.5
    assert meta["provenance"][-1]["tool"] == "evaluate"


def test_cli_refuses_a_session_and_video_with_truth(tmp_path):
    _write(jumps(L_VR), tmp_path / "vr.parquet")
    session = sfio.table_to_bytes(pa.table({"t": [0.0, 0.1]}), sfmeta.new_meta("session", 1.7e9))
    r = run_cli(["evaluate", "--video", str(tmp_path / "vr.parquet"), "-o", str(tmp_path / "o.parquet")], stdin=session)
    assert r.returncode == 1 and r.stdout == b""
    err = r.stderr.decode().strip().splitlines()
    assert len(err) == 1 and err[0].startswith("Error: evaluate: ") and "expected jumps" in err[0]
    r = run_cli(
        ["evaluate", "--video", str(tmp_path / "vr.parquet"), "--truth", "t.parquet", "--format", "text"],
        stdin=session,
    )
    assert r.returncode == 2 and b"does not go with --truth" in r.stderr
