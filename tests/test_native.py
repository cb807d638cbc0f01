"""The optional C extensions: loaded when built; otherwise (or with SPORTFUSION_NATIVE=0) the numpy path runs and
says so once, in one line on stderr, with roughly how much slower it is and how to build the extensions."""

from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest
from conftest import BIN, session_bytes

from sportfusion.core import native


@pytest.fixture
def fresh(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(native, "_told", False)  # as in a new process


def test_optional_extensions_are_loaded_unless_asked_not_to(monkeypatch, fresh, capsys) -> None:  # noqa: ANN001
    monkeypatch.setenv("SPORTFUSION_NATIVE", "1")
    assert native.load_extension("sportfusion.core.rotations") is not None  # an importable module: loaded
    assert capsys.readouterr().err == ""
    monkeypatch.setenv("SPORTFUSION_NATIVE", "0")
    assert native.load_extension("sportfusion.core.rotations") is None  # asked for the numpy path
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sportfusion: SPORTFUSION_NATIVE=0")
    assert "numpy path" in err


def test_a_missing_extension_is_said_once_with_the_cost_and_the_cure(monkeypatch, fresh, capsys) -> None:  # noqa: ANN001
    monkeypatch.delenv("SPORTFUSION_NATIVE", raising=False)
    assert native.load_extension("sportfusion.skijump._no_such_extension") is None  # not built: the numpy path
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "not built" in err and "numpy path" in err and "pip install -e ." in err and "gcc" in err
    # every later extension that is missing stays quiet: one line per process
    assert native.load_extension("sportfusion.climbing._no_such_extension") is None
    assert capsys.readouterr().err == ""
    # each kernel's message names what is slower and about how much
    for name in ("sportfusion.skijump._ski_c", "sportfusion.estimators._banded_c", "sportfusion.climbing._climbing_c"):
        line = native.notice(name, disabled=False)
        assert "x slower" in line and "\n" not in line and name in line


def test_a_command_on_the_numpy_path_says_so_once(tmp_path) -> None:  # noqa: ANN001
    """spline-smooth with SPORTFUSION_NATIVE=0: the same columns, and one line on stderr saying why it is slower."""
    rng = np.random.default_rng(0)
    n = 300
    t = np.arange(n) * 0.1
    cols = {f"gnss_{a}": np.cumsum(rng.normal(size=n)) for a in "xyz"}
    data = session_bytes(cols, n=n)
    out = {}
    for flag in ("1", "0"):
        env = {**os.environ, "SPORTFUSION_NATIVE": flag}
        res = subprocess.run([str(BIN / "spline-smooth"), "-q"], input=data, capture_output=True, env=env, timeout=120)
        assert res.returncode == 0, res.stderr.decode()
        out[flag] = res
    with_c, numpy_path = (out[f].stderr.decode().splitlines() for f in ("1", "0"))
    extra = [line for line in numpy_path if line not in with_c]  # the command's own warnings are the same
    assert len(extra) == 1 and extra[0].startswith("sportfusion: SPORTFUSION_NATIVE=0"), numpy_path
    assert len(numpy_path) == len(with_c) + 1
    from sportfusion.core import io as sfio

    a = sfio.table_from_bytes(out["1"].stdout)
    b = sfio.table_from_bytes(out["0"].stdout)
    assert a.column_names == b.column_names and t.size == a.num_rows
    for c in ("x", "vx", "ax"):
        np.testing.assert_allclose(a.column(c).to_numpy(), b.column(c).to_numpy(), rtol=1e-9, atol=1e-9)
