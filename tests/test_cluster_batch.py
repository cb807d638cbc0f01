"""Batch reprocessing through Snakemake (pipelines/Snakefile, `make cluster-batch`).

The four fixture sessions plus one corrupt session: four results, the corrupt one retried once and then
reported with its error line, the summary complete with the engine in its provenance; a second run does
nothing; changing one session's raw file redoes only that session; a dry run with the SLURM profile
prints the jobs it would submit with their resources.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from sportfusion.batch import session_inputs, session_resources
from sportfusion.core import io as sfio

BIN = Path(sys.executable).parent
SNAKEMAKE = BIN / "snakemake"
SPORTS = ("skijump", "skirace", "gates", "climbing")


def _sessions(root: Path) -> Path:
    sessions = root / "sessions"
    for name in SPORTS:
        shutil.copytree(ROOT / "fixtures" / name, sessions / name)
    shutil.copytree(ROOT / "fixtures" / "climbing", sessions / "corrupt")
    (sessions / "corrupt" / "session.parquet").write_bytes(b"this is not a recording\n")
    return sessions


def _snakemake(sessions: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    cmd = [str(SNAKEMAKE), "-s", str(ROOT / "pipelines" / "Snakefile"), "-d", str(out), "--config"]
    cmd += [f"sessions={sessions}", f"out={out}", f"bin={BIN}/", *extra]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=900)


def test_session_inputs_and_resources(tmp_path: Path) -> None:
    files = session_inputs(ROOT / "fixtures" / "skijump")
    names = {Path(f).name for f in files}
    assert {"config.mk", "phyphox.zip", "gnss.nmea", "truth.parquet", "landing.mp4"} <= names
    size = sum(Path(f).stat().st_size for f in files) / 1e6
    res = session_resources(files)
    assert res["mem_mb"] == int(1000 + 200 * size) and res["runtime"] == int(10 + 2 * size)
    assert session_resources(files, attempt=2)["mem_mb"] == 2 * res["mem_mb"]
    # a config naming a missing file: the session is still scheduled (its pipeline reports the error)
    d = tmp_path / "s"
    d.mkdir()
    (d / "config.mk").write_text("SPORT = climbing\nRAW = gone.parquet\n")
    assert session_inputs(d) == [str(d / "config.mk")]


@pytest.mark.slow
def test_snakemake_batch_retries_reports_and_redoes_only_what_changed(tmp_path: Path) -> None:
    assert SNAKEMAKE.exists(), "the cluster extra (snakemake) is part of the test install: make test installs it"
    sessions, out = _sessions(tmp_path), tmp_path / "out"
    run = subprocess.run(
        ["make", "--no-print-directory", "cluster-batch", f"SESSIONS={sessions}", f"BATCH={out}", f"VENV={BIN.parent}"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=900,
    )
    # one session failed: make says so in one line and fails (make's exit status 2), the others completed
    assert run.returncode == 2, run.stdout[-2000:] + run.stderr[-2000:]
    assert "cluster-batch: 1 session(s) failed" in run.stdout + run.stderr
    table, meta = sfio.read_table(out / "summary.parquet", kind="summary")
    rows = {r["session"]: r for r in table.to_pylist()}
    assert set(rows) == {*SPORTS, "corrupt"}
    assert [n for n, r in rows.items() if r["status"] == "ok"] == sorted(SPORTS)
    assert rows["corrupt"]["status"] == "failed" and rows["corrupt"]["error"].startswith("Error: ")
    assert abs(rows["skijump"]["jump_length"] - 89.6) < 1.0
    step = meta["provenance"][-1]
    assert step["tool"] == "batch" and step["params"]["engine"].startswith("snakemake ")
    assert step["params"]["ok"] == 4 and step["params"]["failed"] == 1
    assert "FAILED corrupt: Error:" in (out / "summary.txt").read_text()
    for name in SPORTS:
        assert (out / name / "log").exists()
    # the failing session was tried twice (one retry), the others once
    logs = "\n".join(p.read_text() for p in (out / ".snakemake" / "log").glob("*.log"))
    assert len(re.findall(r"Trying to restart job", logs)) == 1

    again = _snakemake(sessions, out, "--cores", "2", "-n")
    assert "Nothing to be done" in again.stdout + again.stderr

    nmea = sessions / "skirace" / "raw" / "gnss.nmea"
    nmea.write_text(nmea.read_text() + "\n")  # a changed raw file (a fix): only that session is redone
    dry = _snakemake(sessions, out, "--cores", "2", "-n")
    text = dry.stdout + dry.stderr
    assert re.findall(r"wildcards: name=(\w+)", text) == ["skirace"], text[-3000:]


def test_slurm_profile_dry_run_lists_the_jobs(tmp_path: Path) -> None:
    if not SNAKEMAKE.exists():
        pytest.fail("the cluster extra (snakemake) is part of the test install: make test installs it")
    sessions, out = _sessions(tmp_path), tmp_path / "out"
    dry = _snakemake(sessions, out, "--profile", str(ROOT / "pipelines" / "profiles" / "slurm"), "-n")
    text = dry.stdout + dry.stderr
    assert dry.returncode == 0, text[-3000:]
    assert sorted(re.findall(r"wildcards: name=(\w+)", text)) == sorted([*SPORTS, "corrupt"])
    assert text.count("slurm_partition=normal") >= 5 and "cpus_per_task=1" in text
    assert re.search(r"session\s+5", text) and "This was a dry-run" in text
