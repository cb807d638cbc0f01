"""Batch reprocessing through Snakemake (pipelines/Snakefile, `make cluster-batch`).

The four fixture sessions plus one corrupt session: four results, the corrupt one retried once and then
reported with its error line, the summary complete with the engine in its provenance; a second run does
nothing; changing one session's raw file redoes only that session; with every session ok the exit status
is 0; a lock left by a killed run is refused in one line and UNLOCK=1 removes it; a dry run with the SLURM
profile prints the jobs it would submit with their resources. The SLURM profile's checks against a cluster
(partition, account, MinJobAge, pre-emption) run here on canned answers of sinfo/sacctmgr/scontrol; the
scheduler's error lines on the SLURM plugin's messages. On a real SLURM cluster: pipelines/slurm/test-slurm.sh.
"""

from __future__ import annotations

import getpass
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import yaml
from conftest import ROOT

from sportfusion.batch import (
    check_slurm_profile,
    collect,
    scheduler_error_line,
    session_inputs,
    session_resources,
)
from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta

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


def _make_cluster_batch(sessions: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    cmd = [
        "make",
        "--no-print-directory",
        "cluster-batch",
        f"SESSIONS={sessions}",
        f"BATCH={out}",
        f"VENV={BIN.parent}",
    ]
    return subprocess.run([*cmd, *extra], capture_output=True, text=True, cwd=ROOT, timeout=900)


def test_session_inputs_and_resources(tmp_path: Path) -> None:
    files = session_inputs(ROOT / "fixtures" / "skijump")
    names = {Path(f).name for f in files}
    assert {"config.mk", "phyphox.zip", "gnss.nmea", "truth.parquet", "landing.mp4"} <= names
    size = sum(Path(f).stat().st_size for f in files) / 1e6
    res = session_resources(files)
    assert res["mem_mb"] == int(1000 + 200 * size) and res["runtime"] == int(10 + 2 * size)
    # a retry (on SLURM a new job) asks for twice the memory and twice the time, the next one four times
    assert session_resources(files, attempt=2) == {"mem_mb": 2 * res["mem_mb"], "runtime": 2 * res["runtime"]}
    assert session_resources(files, attempt=3)["mem_mb"] == 4 * res["mem_mb"]
    # a config naming a missing file: the session is still scheduled (its pipeline reports the error)
    d = tmp_path / "s"
    d.mkdir()
    (d / "config.mk").write_text("SPORT = climbing\nRAW = gone.parquet\n")
    assert session_inputs(d) == [str(d / "config.mk")]


@pytest.mark.slow
def test_snakemake_batch_retries_reports_and_redoes_only_what_changed(tmp_path: Path) -> None:
    assert SNAKEMAKE.exists(), "the cluster extra (snakemake) is part of the test install: make test installs it"
    sessions, out = _sessions(tmp_path), tmp_path / "out"
    run = _make_cluster_batch(sessions, out)
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
    # no scheduler here: nothing for the scheduler-error lines to say
    assert "cluster-batch: corrupt:" not in run.stdout + run.stderr

    again = _snakemake(sessions, out, "--cores", "2", "-n")
    assert "Nothing to be done" in again.stdout + again.stderr

    nmea = sessions / "skirace" / "raw" / "gnss.nmea"
    nmea.write_text(nmea.read_text() + "\n")  # a changed raw file (a fix): only that session is redone
    dry = _snakemake(sessions, out, "--cores", "2", "-n")
    text = dry.stdout + dry.stderr
    assert re.findall(r"wildcards: name=(\w+)", text) == ["skirace"], text[-3000:]

    # every session ok (the corrupt one gone, the change undone): make's exit status is 0
    shutil.rmtree(sessions / "corrupt")
    nmea.write_text(nmea.read_text()[:-1])
    ok = _make_cluster_batch(sessions, out)
    assert ok.returncode == 0, ok.stdout[-2000:] + ok.stderr[-2000:]
    assert "4 of 4 sessions ok, 0 failed" in (out / "summary.txt").read_text()

    # a lock that a killed run left: refused in one line naming the way out; UNLOCK=1 removes it
    locks = out / ".snakemake" / "locks"
    locks.mkdir(parents=True, exist_ok=True)
    (locks / "0.input.lock").write_text(str(sessions / "skirace" / "config.mk") + "\n")
    locked = _make_cluster_batch(sessions, out)
    assert locked.returncode == 2 and "is locked" in locked.stdout and "UNLOCK=1" in locked.stdout
    unlocked = _make_cluster_batch(sessions, out, "UNLOCK=1")
    assert unlocked.returncode == 0, unlocked.stdout[-2000:] + unlocked.stderr[-2000:]
    assert f"cluster-batch: unlocked {out}" in unlocked.stdout and not list(locks.glob("*"))


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


def test_scheduler_error_lines() -> None:
    # sbatch's refusal, as snakemake-executor-plugin-slurm reports it: sbatch's own lines, nothing else
    refused = (
        "SLURM sbatch failed. The error message was 'sbatch: error: invalid partition specified: nope\n"
        "sbatch: error: Batch job submission failed: Invalid partition name specified'.\n"
        "    sbatch call:\n        sbatch --parsable --job-name 1f2e -p nope --mem 1044 --wrap=...\n"
    )
    assert scheduler_error_line(refused) == (
        "sbatch refused the job: sbatch: error: invalid partition specified: nope; "
        "sbatch: error: Batch job submission failed: Invalid partition name specified"
    )
    # a job the scheduler ended (here seen by squeue): its id, its state, its SLURM log
    cancelled = (
        "SLURM-job '30' failed, SLURM status is: 'CANCELLED'. Detailed failure reason unavailable (status "
        "command is not 'sacct').For further error details see the cluster/cloud log and the log files"
    )
    log = "/o/skijump/log, ['/o/.snakemake/slurm_logs/rule_session/skijump/30.log']"
    assert scheduler_error_line(cancelled, log) == (
        "SLURM job 30 ended CANCELLED (its log: /o/.snakemake/slurm_logs/rule_session/skijump/30.log)"
    )
    node = "SLURM-job '7' failed due to a node failure, SLURM status is: 'NODE_FAIL'. Failed nodes will be excluded"
    assert scheduler_error_line(node) == "SLURM job 7 ended NODE_FAIL"
    assert scheduler_error_line(None) is None and scheduler_error_line("  ") is None
    assert scheduler_error_line("something\nunexpected") == "something unexpected"


def _fake_cluster(min_job_age: int = 300, preempt: str = "OFF", accounts: str = "lab\nother\n", sacctmgr_rc: int = 0):
    calls: list[list[str]] = []

    def run(argv: list[str]) -> tuple[int, str]:
        calls.append(argv)
        if argv[0] == "sinfo":
            return 0, "batch\ngpu\n"
        if argv[0] == "sacctmgr":
            return (0, accounts) if sacctmgr_rc == 0 else (1, "sacctmgr: error: Problem talking to the database")
        if argv[:3] == ["scontrol", "-o", "show"]:
            return 0, f"PartitionName={argv[-1]} AllowGroups=ALL PreemptMode={preempt} State=UP TotalCPUs=64\n"
        if argv[:3] == ["scontrol", "show", "config"]:
            return 0, f"MaxJobCount             = 10000\nMinJobAge               = {min_job_age} sec\n"
        raise AssertionError(argv)

    return run, calls


def test_the_slurm_profile_is_checked_before_submitting() -> None:
    shipped = yaml.safe_load((ROOT / "pipelines" / "profiles" / "slurm" / "config.yaml").read_text())
    # the shipped profile: status by squeue (sacct's "CANCELLED by <uid>" would hang the plugin), quick polls,
    # SLURM requeues node failures and pre-emptions, one retry
    assert shipped["slurm-status-command"] == "squeue" and shipped["slurm-requeue"] is True
    assert 1 <= shipped["slurm-init-seconds-before-status-checks"] <= 10 and shipped["retries"] == 1
    run, calls = _fake_cluster()
    problems, notes = check_slurm_profile(shipped, "config.yaml", run=run)
    # its placeholders: both named in one line each, with what the cluster has
    assert problems == [
        "partition 'normal' (slurm_partition in config.yaml) is not on this cluster; its partitions: batch, gpu",
        f"account 'your_account' (slurm_account in config.yaml) is not one of {getpass.getuser()}'s SLURM "
        "accounts: lab, other",
    ]
    lab = {
        **shipped,
        "default-resources": {**shipped["default-resources"], "slurm_partition": "batch", "slurm_account": "lab"},
    }
    assert check_slurm_profile(lab, run=_fake_cluster()[0]) == ([], [])
    # the list form of default-resources (snakemake --default-resources k=v ...) reads the same
    listed = {**lab, "default-resources": ["slurm_partition='batch'", "slurm_account=lab", "cpus_per_task=1"]}
    assert check_slurm_profile(listed, run=_fake_cluster()[0]) == ([], [])
    # squeue forgets a finished job after MinJobAge: shorter than the plugin's longest pause is refused
    problems, _ = check_slurm_profile(lab, run=_fake_cluster(min_job_age=60)[0])
    assert len(problems) == 1 and problems[0].startswith("MinJobAge is 60 s on this cluster")
    # a partition that cancels pre-empted jobs would leave the engine waiting
    problems, _ = check_slurm_profile(lab, run=_fake_cluster(preempt="CANCEL")[0])
    assert len(problems) == 1 and "PreemptMode=CANCEL" in problems[0]
    # no accounting database: the account cannot be checked, said in a note, not refused
    problems, notes = check_slurm_profile(lab, run=_fake_cluster(sacctmgr_rc=1)[0])
    assert problems == [] and notes == [
        "the account is not checked: sacctmgr says sacctmgr: error: Problem talking to the database"
    ]
    # sacct as the status command: allowed, with the known hang said in a note
    problems, notes = check_slurm_profile(
        {**lab, "slurm-status-command": "sacct"}, run=_fake_cluster(min_job_age=60)[0]
    )
    assert problems == [] and "CANCELLED by <uid>" in notes[0]
    unset = {k: v for k, v in lab.items() if k != "slurm-status-command"}
    problems, notes = check_slurm_profile(unset, run=_fake_cluster()[0])
    assert problems == [] and "the plugin then uses sacct" in notes[0]
    # not a SLURM profile: nothing to check, nothing run
    run, calls = _fake_cluster()
    assert check_slurm_profile({"executor": "local"}, run=run) == ([], []) and calls == []


def _tables(out: Path) -> None:
    """A climbing session's result table (1.5 m/s) and an evaluation table, both small."""
    t = np.arange(0.0, 10.0, 0.5)
    result = pa.table({"t": t, "vx": np.full_like(t, 1.5), "vy": np.zeros_like(t), "vz": np.zeros_like(t)})
    ev = pa.table({"phase": ["all"], "stat": ["rms"], "x": [0.3], "y": [0.4], "z": [0.0]})
    out.mkdir(parents=True, exist_ok=True)
    sfio.write_bytes(sfio.table_to_bytes(result, sfmeta.new_meta("session")), out / "holds.parquet")
    sfio.write_bytes(sfio.table_to_bytes(ev, sfmeta.new_meta("summary")), out / "evaluation.parquet")


def test_a_session_is_ok_only_when_all_its_declared_outputs_exist(tmp_path: Path) -> None:
    sessions, out = tmp_path / "sessions", tmp_path / "out"
    for name in ("wall1", "wall2", "wall3"):
        shutil.copytree(ROOT / "fixtures" / "climbing", sessions / name)
    session_mk = ROOT / "pipelines" / "session.mk"
    for name in ("wall1", "wall2", "wall3"):
        _tables(out / name)
        for f in ("plots/holds.png", "evaluation.txt", "report.html"):
            (out / name / f).parent.mkdir(parents=True, exist_ok=True)
            (out / name / f).write_text("x")
        (out / name / ".done").write_text("")
    # wall2: a run killed before its evaluation table; wall3: done marker gone (the engine was rerunning it)
    (out / "wall2" / "evaluation.parquet").unlink()
    (out / "wall3" / ".done").unlink()
    rows = {r["session"]: r for r in collect(sessions, out, session_mk, "all", ".done")}
    assert rows["wall1"]["status"] == "ok" and abs(rows["wall1"]["max_speed"] - 1.5) < 1e-12
    assert rows["wall2"]["status"] == "failed"
    assert rows["wall2"]["error"] == "incomplete (an interrupted run?): no evaluation.parquet"
    assert rows["wall3"]["status"] == "failed" and rows["wall3"]["error"].startswith("not finished")
    # the target decides what is declared: results only needs the holds table
    rows = {r["session"]: r for r in collect(sessions, out, session_mk, "results")}
    assert rows["wall2"]["status"] == "ok" and rows["wall3"]["status"] == "ok"
    # without session.mk (the old call): the result table alone decides
    assert {r["status"] for r in collect(sessions, out)} == {"ok"}
