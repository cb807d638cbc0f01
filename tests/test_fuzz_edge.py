"""Property-based fuzz of every command's input edge (issue 17): mangled Parquet, broken metadata,
wrong column types, NaN/inf/huge values, missing columns and nonsense option values never give a
traceback, an internal error, output on stdout after a failure, a multi-line failure message, or
NaN/inf in an estimate column.  The cases come from bench/bench_bad_input.py (which counts them)."""

from __future__ import annotations

import random
import sys
from functools import cache

from conftest import ROOT
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(ROOT / "bench"))
import bench_bad_input as bb  # noqa: E402

COMMANDS = bb.commands()
READERS = sorted(n for n, c in COMMANDS.items() if any(p.name == "input" for p in c.params))
OPTION_CASES = bb.option_cases(COMMANDS)


@cache
def _inputs() -> dict[str, tuple[list[str], bytes]]:
    return bb.base_inputs()


def _check(outcome: bb.Outcome) -> None:
    assert not outcome.problems, (outcome.case, outcome.code, outcome.problems, outcome.stderr[-800:])


FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)


@FUZZ
@given(name=st.sampled_from(READERS), seed=st.integers(0, 2**31 - 1), pick=st.integers(0, 10**6))
def test_corrupted_inputs_at_every_reader(name, seed, pick):
    extra, data = _inputs().get(name, _inputs()["inspect"])
    if not data:
        data = _inputs()["inspect"][1]
    cases = bb.corrupt_inputs(data, random.Random(seed))
    label, bad, refuse = cases[pick % len(cases)]
    _check(bb.judge(f"{name} <{label}>", [*name.split(), *extra], bad, refuse))


@FUZZ
@given(case=st.sampled_from(OPTION_CASES))
def test_nonsense_option_values(case):
    label, argv, refuse = case
    name = label.split(" --")[0]
    assume(name in _inputs())
    extra, data = _inputs()[name]
    _check(bb.judge(label, [*name.split(), *extra, *argv], data, refuse))


@FUZZ
@given(blob=st.binary(max_size=2000), name=st.sampled_from(READERS))
def test_arbitrary_bytes_on_stdin(blob, name):
    extra, _ = _inputs().get(name, ([], b""))
    _check(bb.judge(f"{name} <random bytes>", [*name.split(), *extra], blob, True))
