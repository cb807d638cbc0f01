"""The output layer (issue 38): nothing a command replaces is ever lost.

Identity checks (an output that is an input or another output, by device and inode), special files
(devices, FIFOs, /dev/stdout, /dev/fd/N written in place; symlink targets replaced), multi-output
transactions, signals, NAME_MAX/PATH_MAX.  No test writes to the machine's real /dev: device nodes
and FIFOs are made in tmp folders, and the cases that need /dev itself run in a private mount
namespace whose /dev is a fresh tmpfs (skipped with the reason where that cannot be made).
"""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow as pa
import pytest
from click.testing import CliRunner
from conftest import BIN, ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import outputs as sfout
from sportfusion.core.errors import OutputError, SameFileError

JUMP = ROOT / "fixtures" / "skijump" / "session.parquet"
TRUTH = ROOT / "fixtures" / "skijump" / "truth.parquet"
SURVEY = ROOT / "fixtures" / "gates" / "survey.parquet"
NMEA = ROOT / "fixtures" / "skijump" / "raw" / "gnss.nmea"
ORIGIN = ["--origin", "47.4,10.3,900", "-q"]


def digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def one_error(stderr: bytes | str) -> str:
    text = stderr.decode() if isinstance(stderr, bytes) else stderr
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, text
    assert lines[0].startswith("Error: "), text
    return lines[0]


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in Path(folder).iterdir() if ".tmp" in p.name)


def table_rows(path: Path) -> int:
    table, _ = sfio.read_table(path)
    return table.num_rows


def copy_to(tmp_path: Path, src: Path, name: str | None = None) -> Path:
    dst = tmp_path / (name or src.name)
    shutil.copyfile(src, dst)
    return dst


# -- 1. identity: an output that is an input or another output ---------------------------------------------


def test_ingest_output_onto_its_raw_input_is_refused(tmp_path):
    raw = copy_to(tmp_path, NMEA)
    before = digest(raw)
    r = run_cli(["ingest", str(raw), "-o", str(raw)])
    assert r.returncode == 2, r.stderr
    assert "same file" in one_error(r.stderr) and r.stdout == b""
    assert digest(raw) == before and leftovers(tmp_path) == []


def test_evaluate_output_onto_the_truth_is_refused_also_through_links(tmp_path):
    est = copy_to(tmp_path, JUMP)
    truth = copy_to(tmp_path, TRUTH)
    (tmp_path / "soft.parquet").symlink_to(truth.name)
    os.link(truth, tmp_path / "hard.parquet")
    before = digest(truth)
    for out in (truth, tmp_path / "soft.parquet", tmp_path / "hard.parquet"):
        r = run_cli(["evaluate", str(est), "--truth", str(truth), "-o", str(out)])
        assert r.returncode == 2, r.stderr
        assert "the same file" in one_error(r.stderr)
    assert digest(truth) == before
    assert (tmp_path / "soft.parquet").is_symlink()


def test_gate_anchor_output_onto_its_survey_is_refused(tmp_path):
    survey = copy_to(tmp_path, SURVEY)
    before = digest(survey)
    r = run_cli(["gate-anchor", str(copy_to(tmp_path, JUMP)), "--gates", str(survey), "-o", str(survey)])
    assert r.returncode == 2 and "--gates" in one_error(r.stderr)
    assert digest(survey) == before


def test_two_outputs_naming_one_file_are_refused_before_any_work(tmp_path):
    x = tmp_path / "x.parquet"
    r = run_cli(["simulate", "boulder", "--truth", str(x), "--holds", str(x), "-o", str(x)])
    assert r.returncode == 2, r.stderr
    assert "are the same file" in one_error(r.stderr)
    assert not x.exists() and leftovers(tmp_path) == []
    # two spellings of one new name (through a symlinked folder) are one file too
    (tmp_path / "sub").mkdir()
    (tmp_path / "alias").symlink_to("sub")
    r = run_cli(
        [
            "simulate",
            "boulder",
            "--truth",
            str(tmp_path / "alias" / "t.parquet"),
            "-o",
            str(tmp_path / "sub" / "t.parquet"),
        ]
    )
    assert r.returncode == 2 and "same file" in one_error(r.stderr)


def test_standard_streams_count_as_input_and_output(tmp_path):
    src = copy_to(tmp_path, JUMP)
    before = digest(src)
    with open(src, "ab") as out:  # `gps2hill src >> src`: would append a table to its own input
        r = subprocess.run([str(BIN / "gps2hill"), str(src), *ORIGIN], stdout=out, stderr=subprocess.PIPE, timeout=120)
    assert r.returncode == 2 and "standard output" in one_error(r.stderr)
    with open(src, "rb") as inp:  # `gps2hill < src -o src`
        r = subprocess.run(
            [str(BIN / "gps2hill"), *ORIGIN, "-o", str(src)], stdin=inp, capture_output=True, timeout=120
        )
    assert r.returncode == 2 and "standard input" in one_error(r.stderr)
    assert digest(src) == before


def test_side_inputs_named_by_file_options_are_protected(tmp_path):
    hill = tmp_path / "hill.toml"
    hill.write_text((ROOT / "lib" / "data" / "hills" / "oberstdorf_hs106.toml").read_text())
    r = run_cli(["gps2hill", str(JUMP), "--hill", str(hill), "-o", str(hill)])
    assert r.returncode == 2 and "--hill" in one_error(r.stderr)
    cfg = tmp_path / "tuning.toml"
    cfg.write_text("[rts]\n")
    r = run_cli(["rts-smooth", str(JUMP), "--config", str(cfg), "-o", str(cfg)])
    assert r.returncode == 2 and "--config" in one_error(r.stderr)
    assert cfg.read_text() == "[rts]\n"


def test_a_character_device_may_be_named_twice(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    null = tmp_path / "null"
    os.mknod(null, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    r = run_cli(["simulate", "boulder", "-q", "--truth", str(null), "--holds", str(null), "-o", str(null)])
    assert r.returncode == 0, r.stderr
    assert stat.S_ISCHR(os.lstat(null).st_mode)


def test_reads_during_the_command_are_noted():
    with sfout.Outputs() as out:
        sfio.read_table(TRUTH)
        with pytest.raises(SameFileError, match="same file"):
            out.add_bytes(str(TRUTH), b"x")
    assert sfout.current() is None


# -- 2. special files --------------------------------------------------------------------------------------


def test_fifo_is_written_in_place(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    r = run_cli(["simulate", "boulder", "-q", "-o", str(fifo)])
    reader.join(60)
    assert r.returncode == 0, r.stderr
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    table, meta = sfio.read_table(__import__("io").BytesIO(got[0]))
    assert meta["kind"] == "session" and table.num_rows > 100


def test_character_device_node_in_a_tmp_folder_stays_a_device(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    null = tmp_path / "null"
    os.mknod(null, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    r = run_cli(["gps2hill", str(JUMP), *ORIGIN, "-o", str(null)])
    assert r.returncode == 0, r.stderr
    assert stat.S_ISCHR(os.lstat(null).st_mode) and leftovers(tmp_path) == []


def test_symlink_output_replaces_the_target_and_keeps_the_link(tmp_path):
    (tmp_path / "data").mkdir()
    target = tmp_path / "data" / "real.parquet"
    target.write_bytes(b"old")
    target.chmod(0o640)
    link = tmp_path / "link.parquet"
    link.symlink_to(Path("data") / "real.parquet")
    r = run_cli(["gps2hill", str(JUMP), *ORIGIN, "-o", str(link)])
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and os.readlink(link) == str(Path("data") / "real.parquet")
    assert table_rows(target) > 0
    assert stat.S_IMODE(target.stat().st_mode) == 0o640  # the replaced file's permissions are kept
    assert leftovers(tmp_path / "data") == [] and leftovers(tmp_path) == []


def test_folders_block_devices_and_sockets_are_refused():
    with pytest.raises(OutputError, match="is a folder"):
        sfout.target(str(ROOT))


PRIVATE_DEV = (
    "mount -t tmpfs -o mode=755 tmpfs /dev && mknod -m 666 /dev/null c 1 3 && mknod -m 666 /dev/full c 1 7 "
    "&& ln -s /proc/self/fd /dev/fd && ln -s /proc/self/fd/1 /dev/stdout && ln -s /proc/self/fd/2 /dev/stderr"
)
#: An unprivileged user that can still read the interpreter (which may live in root's home): nobody with
#: CAP_DAC_READ_SEARCH only, so writes are checked as for any user.
AS_NOBODY = (
    "setpriv --reuid=65534 --regid=65534 --clear-groups --inh-caps=+dac_read_search --ambient-caps=+dac_read_search"
)


def private_dev(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run a shell script in a private mount namespace with a fresh /dev (tmpfs, mode 755): null, full, fd,
    stdout, stderr.  The machine's /dev is never touched."""
    if os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("setpriv"):
        pytest.skip("needs root, unshare and setpriv for a private /dev")
    probe = subprocess.run(["unshare", "-m", "sh", "-c", PRIVATE_DEV], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot make a private mount namespace here: {probe.stderr.decode().strip()}")
    os.chmod(tmp_path, 0o777)
    env = dict(os.environ, HOME=str(tmp_path), B=str(BIN), NOBODY=AS_NOBODY)
    return subprocess.run(
        ["unshare", "-m", "sh", "-c", f"{PRIVATE_DEV} && cd {tmp_path} && {script}"],
        capture_output=True,
        env=env,
        timeout=300,
    )


def test_dev_null_dev_stdout_and_dev_fd_as_root_and_as_nobody(tmp_path):
    script = (
        '$NOBODY "$B/simulate" boulder -q --truth /dev/null -o /dev/null; echo "null-nobody $?"; '
        '"$B/simulate" boulder -q --truth /dev/null -o /dev/null; echo "null-root $?"; '
        'test -c /dev/null && echo "null-is-device"; test -L /dev/stdout && echo "stdout-is-link"; '
        '$NOBODY "$B/simulate" boulder -q -o /dev/stdout > via-stdout.parquet; echo "stdout $?"; '
        '$NOBODY "$B/simulate" boulder -q -o /dev/fd/3 3> via-fd3.parquet; echo "fd3 $?"; '
        '"$B/simulate" boulder -q -o /dev/stdout | "$B/inspect" --rows 0 | head -1'
    )
    r = private_dev(script, tmp_path)
    out = r.stdout.decode()
    for line in (
        "null-nobody 0",
        "null-root 0",
        "null-is-device",
        "stdout-is-link",
        "stdout 0",
        "fd3 0",
        "kind: session",
    ):
        assert line in out, (out, r.stderr.decode())
    assert table_rows(tmp_path / "via-stdout.parquet") == table_rows(tmp_path / "via-fd3.parquet") > 100


def test_full_disk_behind_redirection_and_behind_o(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    full = tmp_path / "full"
    os.mknod(full, 0o666 | stat.S_IFCHR, os.makedev(1, 7))  # writes fail with ENOSPC
    with open(full, "wb") as out:  # `gps2hill s > file` on a full disk
        r = subprocess.run([str(BIN / "gps2hill"), str(JUMP), *ORIGIN], stdout=out, stderr=subprocess.PIPE, timeout=120)
    assert r.returncode == 1
    line = one_error(r.stderr)
    assert "No space left on device" in line and "internal" not in line
    r = run_cli(["gps2hill", str(JUMP), *ORIGIN, "-o", str(full)])
    assert r.returncode == 1 and "No space left on device" in one_error(r.stderr)


def test_full_tmpfs_replaces_nothing(tmp_path):
    """A 400 kB tmpfs holding last run's files: the new, bigger outputs do not fit; the old ones stay."""
    script = (
        "mkdir disk && mount -t tmpfs -o size=400k tmpfs disk && "
        '"$B/simulate" boulder -q --seed 1 --truth disk/t.parquet --holds disk/h.parquet --duration 5 -o disk/s.parquet'
        " && cp disk/t.parquet disk/s.parquet disk/h.parquet . && echo old-written && "
        '"$B/simulate" boulder -q --seed 2 --truth disk/t.parquet --holds disk/h.parquet --duration 60 '
        '-o disk/s.parquet; echo "rc $?"; '
        "cmp disk/t.parquet t.parquet && cmp disk/s.parquet s.parquet && cmp disk/h.parquet h.parquet && echo same; "
        'ls -a disk | grep -c tmp; "$B/simulate" boulder -q --seed 2 --duration 60 > disk/x.parquet; echo "redir $?"'
    )
    r = private_dev(script, tmp_path)
    out, err = r.stdout.decode(), r.stderr.decode()
    assert "old-written" in out and "rc 1" in out and "same" in out, (out, err)
    assert out.splitlines()[-2] == "0", out  # no temporary left
    assert "redir 1" in out
    errors = [ln for ln in err.splitlines() if ln.startswith("Error:")]
    assert errors and all("No space left on device" in e for e in errors), err


# -- 3. several outputs: one transaction ---------------------------------------------------------------------


def test_a_failed_side_output_replaces_nothing(tmp_path, monkeypatch):
    for name in ("t.parquet", "h.parquet", "s.parquet"):
        (tmp_path / name).write_bytes(b"old " + name.encode())
    real = sfout.Outputs.add_stream
    calls = []

    def fail_second(self, dest, write, label=None):
        calls.append(dest)
        if len(calls) == 2:
            raise OutputError(f"cannot write {dest}: No space left on device")
        return real(self, dest, write, label)

    monkeypatch.setattr(sfout.Outputs, "add_stream", fail_second)
    from sportfusion.tools.simulate import main

    args = ["boulder", "-q", "--truth", str(tmp_path / "t.parquet"), "--holds", str(tmp_path / "h.parquet")]
    res = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "s.parquet")])
    assert res.exit_code == 1 and "No space left" in res.stderr
    for name in ("t.parquet", "h.parquet", "s.parquet"):
        assert (tmp_path / name).read_bytes() == b"old " + name.encode()
    assert leftovers(tmp_path) == []


def test_outputs_commit_together_and_abort_removes_every_temporary(tmp_path):
    with pytest.raises(RuntimeError), sfout.Outputs() as out:
        out.add_bytes(str(tmp_path / "a.txt"), b"a")
        out.add_folder(str(tmp_path / "raw"), lambda d: (d / "x.csv").write_text("1"))
        assert len(leftovers(tmp_path)) == 2  # the temporaries exist, the destinations do not
        raise RuntimeError("the command failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    (tmp_path / "raw").mkdir()
    (tmp_path / "raw" / "keep.csv").write_text("kept")
    with sfout.Outputs() as out:
        out.add_bytes(str(tmp_path / "a.txt"), b"a")
        out.add_folder(
            str(tmp_path / "raw"),
            lambda d: ((d / "x.csv").write_text("1"), (d / "sub").mkdir(), (d / "sub" / "y.xml").write_text("<y/>")),
        )
        out.add_file(str(tmp_path / "v.mp4"), lambda p: Path(p).write_bytes(b"video") if p.endswith(".mp4") else None)
    assert (tmp_path / "a.txt").read_bytes() == b"a" and (tmp_path / "v.mp4").read_bytes() == b"video"
    assert sorted(p.name for p in (tmp_path / "raw").iterdir()) == ["keep.csv", "sub", "x.csv"]
    assert (tmp_path / "raw" / "sub" / "y.xml").read_text() == "<y/>"
    assert leftovers(tmp_path) == [] and leftovers(tmp_path / "raw") == []


def test_skijump_side_outputs_raw_folder_and_truth(tmp_path):
    r = run_cli(
        [
            "simulate",
            "skijump",
            "-q",
            "--seed",
            "3",
            "--truth",
            str(tmp_path / "t.parquet"),
            "--raw",
            str(tmp_path / "raw"),
            "-o",
            str(tmp_path / "s.parquet"),
        ]
    )
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "raw").iterdir()) == ["gnss.nmea", "phyphox.zip"]
    assert table_rows(tmp_path / "t.parquet") == table_rows(tmp_path / "s.parquet") > 1000
    assert leftovers(tmp_path) == []
    # a raw file of the folder output may not be an input either
    r = run_cli(
        ["simulate", "skijump", "-q", "--raw", str(tmp_path / "raw"), "--truth", str(tmp_path / "raw" / "gnss.nmea")]
    )
    assert r.returncode == 2 and "same file" in one_error(r.stderr)


# -- 4. signals, NAME_MAX, PATH_MAX ---------------------------------------------------------------------------

HOLDER = """
import sys, time
from sportfusion.core import outputs
outputs.install_signal_handlers()
out = outputs.Outputs()
out.add_bytes(sys.argv[1], b"partial")
out.add_folder(sys.argv[2], lambda d: (d / "a.csv").write_text("1"))
print("ready", flush=True)
time.sleep(60)
"""


def _default_signals() -> None:
    """The child starts with the default handlers: a test suite run in the background (``pytest &`` from a
    script) starts with SIGINT ignored, and a command keeps a signal its caller ignores (as it should)."""
    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, signal.SIG_DFL)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])
def test_signals_remove_the_temporaries_and_exit_128_plus_signo(tmp_path, sig):
    p = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(tmp_path / "out.parquet"), str(tmp_path / "raw")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=_default_signals,
    )
    assert p.stdout.readline().strip() == b"ready"
    assert len(leftovers(tmp_path)) == 2
    p.send_signal(sig)
    _, err = p.communicate(timeout=30)
    assert p.returncode == 128 + sig
    assert sorted(tmp_path.iterdir()) == []
    assert b"Traceback" not in err and len(err.splitlines()) <= 1


def _handlers_installed(pid: int) -> bool:
    try:
        caught = next(ln for ln in Path(f"/proc/{pid}/status").read_text().splitlines() if ln.startswith("SigCgt:"))
    except (OSError, StopIteration):
        return False
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGTERM - 1)))


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_console_script_interrupted_while_starting_has_no_traceback(tmp_path, sig):
    if not Path("/proc/self/status").exists():
        pytest.skip("needs /proc to see when the handlers are in place")
    r, w = os.pipe()  # stdin stays open: the command waits for its input after the imports
    p = subprocess.Popen(
        [str(BIN / "rts-smooth"), "-o", str(tmp_path / "o.parquet")],
        stdin=r,
        stderr=subprocess.PIPE,
        preexec_fn=_default_signals,
    )
    os.close(r)
    deadline = time.monotonic() + 60
    while not _handlers_installed(p.pid) and time.monotonic() < deadline:
        time.sleep(0.005)
    p.send_signal(sig)  # while the command's modules are still being imported, or it waits for stdin
    _, err = p.communicate(timeout=60)
    os.close(w)
    assert p.returncode == 128 + sig, err
    assert b"Traceback" not in err and len(err.splitlines()) <= 1, err
    assert sorted(tmp_path.iterdir()) == []


def test_temporary_names_fit_name_max():
    for name in ("a" * 255, "é" * 127, "x.parquet", "a" * 246 + ".parquet", "\udcff" * 200):
        for suffix in ("", ".mp4", ".d"):
            tmp = sfout.temp_name(name, suffix)
            assert len(os.fsencode(tmp)) <= sfout.NAME_MAX and tmp.startswith(".") and tmp.endswith(".tmp" + suffix)
    assert sfout.temp_name("x.parquet") != sfout.temp_name("x.parquet")


def test_legal_long_file_name_is_written_and_too_long_is_named(tmp_path):
    out = tmp_path / ("a" * 247 + ".parquet")  # 255 bytes: legal
    r = run_cli(["gps2hill", str(JUMP), *ORIGIN, "-q", "-o", str(out)])
    assert r.returncode == 0, r.stderr
    assert table_rows(out) > 0
    r = run_cli(["gps2hill", str(JUMP), *ORIGIN, "-q", "-o", str(tmp_path / ("a" * 248 + ".parquet"))])
    assert r.returncode == 1 and "File name too long" in one_error(r.stderr)


def test_working_directory_deeper_than_path_max(tmp_path):
    home = os.open(".", os.O_RDONLY)
    try:
        os.chdir(tmp_path)
        for _ in range(18):  # 18 x 251 bytes: beyond PATH_MAX (4096)
            os.mkdir("d" * 250)
            os.chdir("d" * 250)
        shutil.copyfile(JUMP, "in.parquet")
        r = subprocess.run(
            [str(BIN / "gps2hill"), "in.parquet", *ORIGIN, "-q", "-o", "out.parquet"], capture_output=True, timeout=120
        )
        assert r.returncode == 0, r.stderr
        with open("redir.parquet", "wb") as fh:
            r2 = subprocess.run(
                [str(BIN / "gps2hill"), "in.parquet", *ORIGIN, "-q"], stdout=fh, stderr=subprocess.PIPE, timeout=120
            )
        assert r2.returncode == 0, r2.stderr
        assert sfio.read_table("out.parquet")[0].num_rows == sfio.read_table("redir.parquet")[0].num_rows > 0
        assert [n for n in os.listdir(".") if ".tmp" in n] == []
    finally:
        os.fchdir(home)
        os.close(home)
        subprocess.run(["rm", "-rf", str(tmp_path / ("d" * 250))], check=False)


# -- the API of the frame --------------------------------------------------------------------------------------


def test_tool_write_side_adds_provenance_and_commits_with_the_main_output(tmp_path):
    from sportfusion.tools._cli import Tool

    t = Tool("demo", None, str(tmp_path / "main.parquet"), False, True)
    table = pa.table({"t": [0.0, 0.01, 0.02]})
    t.write_side(str(tmp_path / "side.parquet"), table, sfmeta.new_meta("session"), {"k": 1})
    assert not (tmp_path / "side.parquet").exists()  # waits for the main output
    t.write(table, sfmeta.new_meta("session"))
    _, meta = sfio.read_table(tmp_path / "side.parquet")
    assert meta["provenance"][-1]["tool"] == "demo" and meta["provenance"][-1]["params"] == {"k": 1}
    assert table_rows(tmp_path / "main.parquet") == 3


def test_library_writes_inside_a_command_join_its_transaction(tmp_path):
    with sfout.Outputs():
        sfio.write_bytes(b"x", tmp_path / "lib.txt")
        assert not (tmp_path / "lib.txt").exists()
    assert (tmp_path / "lib.txt").read_bytes() == b"x"
    sfio.write_bytes(b"y", tmp_path / "lib.txt")  # outside a command: at once
    assert (tmp_path / "lib.txt").read_bytes() == b"y"


def test_printable_escapes_what_a_line_cannot_show():
    assert sfout.printable("a\nb.parquet") == "a\\nb.parquet"
    assert sfout.printable(os.fsdecode(b"x\xff\x89.csv")) == "x\\xff\\x89.csv"
    assert sfout.printable("plain é.parquet") == "plain é.parquet"
    assert errno.ENAMETOOLONG  # (used by the message for a name over NAME_MAX)
