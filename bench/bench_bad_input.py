"""Bad input at every command's edge: count internal errors, multi-line messages, corrupted inputs
accepted and NaN/inf written into estimate columns.

Every console script is run in-process (click's test runner, ``-q``) on a few hundred malformed
cases built from the shipped fixtures: truncated and byte-flipped Parquet, broken or out-of-range
metadata, wrong column types, NaN/inf/huge values in columns, missing columns, and nonsense
values (NaN, inf, 1e300, -1e300, 1e-300, empty) for every float option.  A case passes when the
exit code is 0, 1 or 2, nothing is on stdout unless it is 0, a failure says one line (exit 1) or
one ``Error:`` line after click's usage lines (exit 2), no traceback nor "internal error" appears,
a nonsense option value is refused, and a written table holds no NaN/inf in an estimate column.

Run: ``.venv/bin/python bench/bench_bad_input.py [--cases N]`` (about a minute).
"""

from __future__ import annotations

import argparse
import importlib
import io
import json
import random
import sys
import tempfile
import tomllib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import click
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
FIX = ROOT / "fixtures"
TMP = Path(tempfile.mkdtemp(prefix="sf-bad-input-"))

#: Raw sensor columns: NaN there may come from the file itself (not an estimate).
RAW_PREFIXES = ("acc_", "gyr_", "mag_", "vel_", "dev_q", "true_", "gnss_sigma", "gnss_sd")
RAW_NAMES = {"t", "lat", "lon", "h", "h_msl", "pressure", "gnss_hdop", "gnss_speed", "gnss_course", "gnss_age"}


def commands() -> dict[str, click.Command]:
    """'name [sub]' -> click command for every console script (group subcommands included)."""
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    out: dict[str, click.Command] = {}
    for name, target in sorted(scripts.items()):
        module, func = target.split(":")
        cmd = getattr(importlib.import_module(module), func)
        if isinstance(cmd, click.Group):
            for sub, c in sorted(cmd.commands.items()):
                out[f"{name} {sub}"] = c
        else:
            out[name] = cmd
    return out


def _main(name: str) -> click.Command:
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    module, func = scripts[name.split()[0]].split(":")
    return getattr(importlib.import_module(module), func)


@dataclass
class Outcome:
    case: str
    code: int
    stdout: bytes
    stderr: str
    must_refuse: bool = False
    problems: list[str] = field(default_factory=list)


def run(argv: list[str], stdin: bytes = b"") -> tuple[int, bytes, str]:
    """Run a command line in-process; (exit code, stdout bytes, stderr text)."""
    cmd = _main(argv[0])
    res = CliRunner().invoke(cmd, [*argv[1:], "-q"], input=stdin)
    code = res.exit_code if isinstance(res.exit_code, int) else 1
    err = res.stderr
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        err += f"\nTraceback (uncaught {type(res.exception).__name__}: {res.exception})"
        code = 99
    return code, res.stdout_bytes, err


def _nonfinite_estimates(data: bytes) -> list[str]:
    try:
        table = pq.read_table(io.BytesIO(data))
    except Exception:  # noqa: BLE001 - not a table (an image, CSV): nothing to check
        return []
    bad = []
    for name in table.column_names:
        col = table.column(name)
        if name in RAW_NAMES or name.startswith(RAW_PREFIXES) or not pa.types.is_floating(col.type):
            continue
        v = col.to_numpy(zero_copy_only=False)
        if np.isinf(v).any() or (np.isnan(v).sum() > col.null_count):
            bad.append(name)
    return bad


def judge(case: str, argv: list[str], stdin: bytes = b"", must_refuse: bool = False) -> Outcome:
    code, out, err = run(argv, stdin)
    o = Outcome(case, code, out, err, must_refuse)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code not in (0, 1, 2) or "Traceback" in err or "internal error" in err:
        o.problems.append("internal")
    if code != 0 and out:
        o.problems.append("stdout on failure")
    if code == 1 and len(lines) != 1:
        o.problems.append("multi-line")
    if code == 2 and sum(ln.startswith("Error:") for ln in lines) != 1:
        o.problems.append("multi-line")
    if code == 0 and must_refuse:
        o.problems.append("accepted")
    if code == 0:
        target = out
        if "-o" in argv:
            p = Path(argv[argv.index("-o") + 1])
            target = p.read_bytes() if p.is_file() and p.suffix == ".parquet" else b""
        if _nonfinite_estimates(target):
            o.problems.append("nan-output")
    return o


# ---------------------------------------------------------------------------------------------------
# inputs


def _slice(path: Path, rows: int) -> bytes:
    table = pq.read_table(path)
    table = table.slice(0, rows).replace_schema_metadata(table.schema.metadata)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def base_inputs() -> dict[str, tuple[list[str], bytes]]:
    """A small valid input (argv extras, stdin bytes) for every command."""
    jump = _slice(FIX / "skijump" / "session.parquet", 600)
    climb = _slice(FIX / "climbing" / "session.parquet", 600)
    holds = str(FIX / "climbing" / "holds.parquet")
    survey = str(FIX / "gates" / "survey.parquet")
    code, race, _ = run(["simulate", "skirace", "--duration", "12", "--static", "2"])
    code2, race_local, _ = run(["gps2hill", "--origin", "46.4975,9.8365,2200", "--azimuth", "160"], race)
    code3, jump_ev, _ = run(["detect-events", "--kind", "jump"], jump)
    code4, climb_grips, _ = run(["detect-events", "--kind", "grips"], climb)
    png = str(TMP / "out.png")
    return {
        "inspect": ([], jump),
        "gps2hill": (["--hill", "oberstdorf_hs106"], jump),
        "spline-smooth": ([], race_local),
        "dmc-attitude": ([], race),
        "detect-events": (["--kind", "jump"], jump),
        "rts-smooth": (["--hill", "oberstdorf_hs106"], jump_ev),
        "jump-metrics": (["--hill", "oberstdorf_hs106"], jump_ev),
        "gate-anchor": (["--gates", survey], jump),
        "pf-holds": (["--holds", holds], climb_grips),
        "evaluate": (["--truth", str(FIX / "skijump" / "truth.parquet")], jump),
        "compare-runs": ([], jump),
        "report": (["-o", str(TMP / "r.html")], jump),
        "plot track": (["-o", png], jump),
        "plot speed": (["-o", png], jump),
        "plot series": (["-o", png], jump),
        "plot mag": (["-o", png], jump),
        "plot hill": (["-o", png, "--hill", "oberstdorf_hs106"], b""),
        "video-jumplength": ([str(FIX / "skijump" / "raw" / "landing.mp4")], b""),
        "ingest": ([str(FIX / "raw" / "qstarz_jump.nmea")], b""),
        "simulate skirace": (["--duration", "10"], b""),
        "simulate boulder": (["--duration", "5"], b""),
    }


def _meta_of(data: bytes) -> dict:
    return json.loads(pq.read_schema(io.BytesIO(data)).metadata[b"sportfusion"])


def _with_meta(data: bytes, meta: dict | bytes) -> bytes:
    table = pq.read_table(io.BytesIO(data))
    raw = meta if isinstance(meta, bytes) else json.dumps(meta).encode()
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), b"sportfusion": raw})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def _with_column(data: bytes, name: str, values: pa.Array) -> bytes:
    table = pq.read_table(io.BytesIO(data))
    md = table.schema.metadata
    if name in table.column_names:
        table = table.set_column(table.column_names.index(name), name, values)
    else:
        table = table.append_column(name, values)
    table = table.replace_schema_metadata(md)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def _drop_columns(data: bytes, keep: tuple[str, ...] = ("t",)) -> bytes:
    table = pq.read_table(io.BytesIO(data))
    return _rebuild(table.select(list(keep)), table)


def _rebuild(table: pa.Table, like: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table.replace_schema_metadata(like.schema.metadata), sink)
    return sink.getvalue().to_pybytes()


def corrupt_inputs(data: bytes, rng: random.Random) -> list[tuple[str, bytes, bool]]:
    """(label, bytes, must_refuse) variants of a valid session table."""
    out: list[tuple[str, bytes, bool]] = []
    out.append(("truncated", data[: rng.randrange(1, len(data))], True))
    for k in range(2):
        b = bytearray(data)
        for _ in range(8):
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
        out.append((f"flipped{k}", bytes(b), False))
    meta = _meta_of(data)
    out.append(("meta-not-json", _with_meta(data, b"{not json"), True))
    out.append(("meta-version", _with_meta(data, {**meta, "version": 99}), True))
    out.append(("meta-year-9999", _with_meta(data, {**meta, "time": {"epoch_utc": "9999-01-01T00:00:00Z"}}), True))
    frame = {"name": "hill", "origin": [91.0, 10.0, 900.0], "azimuth_deg": 0.0, "axes": "x forward, y right, z down"}
    out.append(("meta-lat-91", _with_meta(data, {**meta, "frame": frame}), True))
    n = pq.read_metadata(io.BytesIO(data)).num_rows
    out.append(("acc-as-string", _with_column(data, "acc_x", pa.array(["x"] * n)), True))
    out.append(("only-t", _drop_columns(data), False))
    for label, value in (("nan", np.nan), ("inf", np.inf), ("huge", 1e300)):
        for col in ("acc_x", "gyr_z", "mag_x", "lat"):
            v = np.full(n, value)
            out.append((f"{col}-{label}", _with_column(data, col, pa.array(v)), False))
    return out


NONSENSE = ("nan", "inf", "-inf", "1e300", "-1e300", "1e-300", "")
#: Option values a command may legitimately accept (documented 'inf': off).
INF_OFF = {"--mean-threshold", "--acc-threshold", "--max-flight-acc"}


def option_cases(cmds: dict[str, click.Command]) -> list[tuple[str, list[str], bool]]:
    """(label, extra argv, must_refuse) for every float option and list option of every command."""
    out = []
    for name, cmd in cmds.items():
        for p in cmd.params:
            if not isinstance(p, click.Option) or p.is_flag:
                continue
            opt = max(p.opts, key=len)
            is_float = isinstance(p.type, click.types.FloatParamType)
            is_list = p.metavar in ("LAT,LON,H", "N,E,D", "X,Y,Z", "SIGMA,TAU", "START,END", "T[,T..]")
            if not (is_float or is_list or opt in ("--hill-set", "--route")):
                continue
            for v in NONSENSE:
                if opt == "--hill-set":
                    value = f"e={v}"
                elif is_list:
                    n = p.metavar.count(",") + 1 if p.metavar != "T[,T..]" else 1
                    value = ",".join(["1"] * (n - 1) + [v]) if v else ""
                else:
                    value = v
                refuse = v != "1e-300" and not (opt in INF_OFF and v == "inf")
                out.append((f"{name} {opt}={value!r}", [opt, value], refuse))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--show", type=int, default=15, help="failing cases to print")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    cmds = commands()
    inputs = base_inputs()
    results: list[Outcome] = []
    for name, cmd in cmds.items():
        if not any(p.name == "input" for p in cmd.params):
            continue
        extra, data = inputs.get(name, inputs["inspect"])
        if not data:
            continue
        for label, bad, refuse in corrupt_inputs(data, rng):
            results.append(judge(f"{name} <{label}>", [*name.split(), *extra], bad, refuse))
    for label, argv, refuse in option_cases(cmds):
        name = label.split(" --")[0]
        extra, data = inputs.get(name, ([], b""))
        if name not in inputs:
            continue
        results.append(judge(label, [*name.split(), *extra, *argv], data, refuse))
    # side files and outputs
    binary = TMP / "calib.csv"
    binary.write_bytes(bytes(range(256)) * 64)
    extra, data = inputs["detect-events"]
    results.append(
        judge(
            "calibration binary",
            ["detect-events", "--kind", "gates", "--magnet-calibration", str(binary)],
            data,
            True,
        )
    )
    results.append(judge("-o missing folder", ["inspect", "-o", str(TMP / "no" / "x.parquet")], data, True))
    counts = Counter(p for o in results for p in set(o.problems))
    print(f"bad-input cases: {len(results)}")
    for key in ("internal", "multi-line", "accepted", "nan-output", "stdout on failure"):
        print(f"  {key:18s} {counts.get(key, 0)}")
    shown = 0
    for o in results:
        if o.problems and shown < args.show:
            last = (o.stderr.strip().splitlines() or [""])[-1][:160]
            print(f"  [{','.join(o.problems)}] {o.case}: exit {o.code}: {last}")
            shown += 1


if __name__ == "__main__":
    sys.exit(main())
