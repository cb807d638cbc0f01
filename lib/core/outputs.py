"""Where a command's outputs go and how they replace what was there: nothing is lost, ever.

The rules every output of every command follows (docs/bad-input.md, "Outputs"):

* **Regular files** (or a name that does not exist yet) are written to a temporary file in the same
  folder and renamed over the target once complete, so a failed or interrupted run leaves the old
  file as it was.  The temporary is ``.NAME.XXXXXXXX.tmp`` (shortened with a hash of NAME where that
  would exceed NAME_MAX, 255 bytes); the replaced file keeps its permission bits.
* Through a **symbolic link** the link's final target is written that way; the link stays a link.
* **Character devices** (``/dev/null``), **FIFOs**, ``/dev/stdout``, ``/dev/stderr``, ``/dev/fd/N`` and
  ``/proc/self/fd/N`` are written in place, like the shell's ``>`` does (``/dev/fd/N``: the open
  descriptor N itself, at its offset).  A folder, a block device or a socket is refused.
* **Several outputs of one command** (a session and its truth, a survey, a folder of raw files) are one
  :class:`Outputs` transaction: every temporary is written first, then the in-place outputs (standard
  output, FIFOs, devices), then all renames, with SIGINT/SIGTERM/SIGHUP held back during the renames; a
  failure before the renames replaces nothing.
* **Identity**: an output that is the same file as an input or as another output of the command
  (the same device and inode, through symbolic and hard links alike) is refused with
  :class:`~sportfusion.core.errors.SameFileError`.  Character devices are exempt (``/dev/null`` twice
  is fine).
* **Signals**: live temporaries are kept in a registry; :func:`install_signal_handlers` (a console
  script's first import does it) removes them on SIGINT, SIGTERM and SIGHUP and exits with 128 + the
  signal number.
* **Long paths**: a folder is opened once and every temporary, rename and removal is relative to
  that directory descriptor, so a working directory deeper than PATH_MAX works wherever ``>`` does.

Library code writes through :func:`sportfusion.core.io.write_table` / ``write_bytes``; while a
command's transaction is open (:func:`current`) those join it, so they commit with the rest.
"""

from __future__ import annotations

import contextlib
import os
import signal
import stat
import sys
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, BinaryIO, TypeVar

from sportfusion.core.errors import OutputError, SameFileError
from sportfusion.core.paths import (
    NAME_MAX,
    Identity,
    Target,
    fd_identity,
    follow_links,
    identity,
    os_reason,
    printable,
    stream_fd,
    target,
    target_is_descriptor,
)

__all__ = [
    "NAME_MAX",
    "Identity",
    "Outputs",
    "Target",
    "current",
    "fd_identity",
    "identity",
    "install_signal_handlers",
    "note_read",
    "printable",
    "remove_temporaries",
    "scratch_file",
    "stream_fd",
    "target",
    "target_is_descriptor",
    "temp_name",
]

if TYPE_CHECKING:
    from pathlib import Path

T = TypeVar("T")

#: Above this many bytes a path handed to a producer goes through ``/proc/self/fd/N`` (PATH_MAX is 4096).
_LONG_PATH = 3800

# -- temporaries and the signal handlers ---------------------------------------------------------------
#: Temporaries that exist now: key -> (directory descriptor or None, name, is a folder).
_LIVE: dict[int, tuple[int | None, str, bool]] = {}
_SERIAL = 0
_HELD = ("SIGINT", "SIGTERM", "SIGHUP")


def _register(dfd: int | None, name: str, is_dir: bool) -> int:
    global _SERIAL
    _SERIAL += 1
    key = _SERIAL
    _LIVE[key] = (dfd, name, is_dir)
    return key


def _remove(dfd: int | None, name: str, is_dir: bool) -> None:
    try:
        if is_dir:
            import shutil  # (only a folder output needs it)

            shutil.rmtree(name, dir_fd=dfd) if dfd is not None else shutil.rmtree(name)
        else:
            os.unlink(name, dir_fd=dfd)
    except OSError:
        pass


def remove_temporaries() -> None:
    """Remove every temporary this process has not committed yet (what a signal handler does first)."""
    for key in list(_LIVE):
        entry = _LIVE.pop(key, None)
        if entry is not None:
            _remove(*entry)


def _on_signal(signo: int, frame: object) -> None:
    remove_temporaries()
    if signo != getattr(signal, "SIGINT", -1):  # Ctrl-C speaks for itself; a batch log gets one line
        name = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else "sportfusion"
        try:
            sig = signal.Signals(signo).name
        except ValueError:
            sig = str(signo)
        try:
            os.write(2, f"Error: {name}: stopped by {sig}; unfinished outputs removed\n".encode())
        except OSError:
            pass
    os._exit(128 + signo)


@contextlib.contextmanager
def scratch_file(suffix: str = "") -> Iterator[str]:
    """A temporary file in the system's temporary folder for the duration of a ``with`` block (removed on
    leaving it and by the signal handlers)."""
    import tempfile

    fd, tmp = tempfile.mkstemp(suffix=suffix, prefix=".sportfusion.")
    os.close(fd)
    key = _register(None, tmp, False)
    try:
        yield tmp
    finally:
        _LIVE.pop(key, None)
        _remove(None, tmp, False)


def install_signal_handlers() -> None:
    """SIGINT, SIGTERM, SIGHUP: remove the live temporaries, exit 128 + signal number, no traceback.

    A signal the process was started with ignored (``nohup``, a background job) stays ignored.
    """
    for name in _HELD:
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            if signal.getsignal(sig) == signal.SIG_IGN:
                continue
            signal.signal(sig, _on_signal)
        except (ValueError, OSError, TypeError):  # not the main thread, or no such signal here
            pass


class _Held:
    """Hold SIGINT/SIGTERM/SIGHUP back while the renames of a commit run (delivered right after)."""

    def __enter__(self) -> None:
        sigs = {getattr(signal, n) for n in _HELD if hasattr(signal, n)}
        try:
            self.old: set[signal.Signals] | None = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
        except (AttributeError, OSError, ValueError):
            self.old = None

    def __exit__(self, *exc: object) -> None:
        if self.old is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, self.old)


def temp_name(name: str, suffix: str = "") -> str:
    """A fresh temporary name for ``name`` in its folder: ``.NAME.XXXXXXXX.tmp`` + ``suffix``, within NAME_MAX."""
    tag = os.urandom(4).hex()
    full = f".{name}.{tag}.tmp{suffix}"
    if len(os.fsencode(full)) <= NAME_MAX:
        return full
    import hashlib

    digest = hashlib.sha1(os.fsencode(name)).hexdigest()[:10]
    room = NAME_MAX - len(os.fsencode(f".~{digest}.{tag}.tmp{suffix}"))
    short = os.fsdecode(os.fsencode(name)[: max(room, 0)])
    return f".{short}~{digest}.{tag}.tmp{suffix}"


def _open_folder(folder: str, label: str) -> int:
    try:
        return os.open(folder or ".", os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except FileNotFoundError as exc:
        raise OutputError(f"cannot write {label}: the folder {printable(folder)} does not exist") from exc
    except NotADirectoryError as exc:
        raise OutputError(f"cannot write {label}: {printable(folder)} is not a folder") from exc
    except OSError as exc:
        raise OutputError(f"cannot write {label}: {os_reason(exc)}") from exc


def _path_in(folder: str, dfd: int, name: str) -> str:
    """A path a producer can open for ``name`` in the folder open as ``dfd`` (also beyond PATH_MAX)."""
    path = os.path.join(folder, name) if folder else name
    if len(os.fsencode(path)) < _LONG_PATH:
        return path
    return f"/proc/self/fd/{dfd}/{name}"


class _Staged:
    """A temporary file or folder waiting to be renamed over its destination."""

    def __init__(self, label: str, folder: str, name: str, suffix: str = "", is_dir: bool = False) -> None:
        self.label, self.folder, self.name, self.is_dir = label, folder, name, is_dir
        self.dfd = _open_folder(folder, label)
        self.tmp = ""
        self.key = 0
        self.merge = False  # a folder output into a folder that exists: its entries are moved in
        self.suffix = suffix

    def create_file(self) -> int:
        """Create the temporary file (mode 0666 less the umask, like ``>``); return its descriptor."""
        for _ in range(100):
            self.tmp = temp_name(self.name, self.suffix)
            try:
                fd = os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666, dir_fd=self.dfd)
            except FileExistsError:
                continue
            except OSError as exc:
                self.close()
                raise OutputError(f"cannot write {self.label}: {os_reason(exc)}") from exc
            self.key = _register(self.dfd, self.tmp, False)
            self._keep_mode(fd)
            return fd
        self.close()
        raise OutputError(f"cannot write {self.label}: no free temporary name")

    def _keep_mode(self, fd: int) -> None:
        """The replaced file's permission bits (and, as root, its owner) go to its replacement."""
        try:
            st = os.stat(self.name, dir_fd=self.dfd)
        except OSError:
            return
        if not stat.S_ISREG(st.st_mode):
            return
        try:
            os.fchmod(fd, stat.S_IMODE(st.st_mode) & 0o777)
            if os.geteuid() == 0 and (st.st_uid, st.st_gid) != (0, 0):
                os.fchown(fd, st.st_uid, st.st_gid)
        except OSError:
            pass

    def create_dir(self) -> str:
        """Create the temporary folder; return a path a producer can write into."""
        for _ in range(100):
            self.tmp = temp_name(self.name or "sportfusion", ".d")
            try:
                os.mkdir(self.tmp, 0o777, dir_fd=self.dfd)
            except FileExistsError:
                continue
            except OSError as exc:
                self.close()
                raise OutputError(f"cannot write {self.label}: {os_reason(exc)}") from exc
            self.key = _register(self.dfd, self.tmp, True)
            return _path_in(self.folder, self.dfd, self.tmp)
        self.close()
        raise OutputError(f"cannot write {self.label}: no free temporary name")

    def discard(self) -> None:
        if self.key:
            _LIVE.pop(self.key, None)
            _remove(self.dfd, self.tmp, self.is_dir)
            self.key = 0
        self.close()

    def close(self) -> None:
        if self.dfd >= 0:
            try:
                os.close(self.dfd)
            except OSError:
                pass
            self.dfd = -1

    def produced(self) -> Iterator[str]:
        """The files of a folder output, as paths relative to its destination."""
        root = _path_in(self.folder, self.dfd, self.tmp)
        for base, _dirs, files in os.walk(root):
            rel = os.path.relpath(base, root)
            for f in files:
                yield f if rel == "." else os.path.join(rel, f)

    def rename(self) -> None:
        if self.is_dir and self.merge:
            src = os.open(self.tmp, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC, dir_fd=self.dfd)
            try:
                _merge(src, self.dfd)
            finally:
                os.close(src)
            _remove(self.dfd, self.tmp, True)
        else:
            os.replace(self.tmp, self.name, src_dir_fd=self.dfd, dst_dir_fd=self.dfd)
        _LIVE.pop(self.key, None)
        self.key = 0


def _merge(src: int, dst: int) -> None:
    """Move every entry of the folder open as ``src`` into the one open as ``dst`` (files replace files)."""
    for entry in list(os.scandir(src)):
        if entry.is_dir(follow_symlinks=False):
            try:
                sub_dst = os.open(entry.name, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC, dir_fd=dst)
            except FileNotFoundError:
                os.rename(entry.name, entry.name, src_dir_fd=src, dst_dir_fd=dst)
                continue
            sub_src = os.open(entry.name, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC, dir_fd=src)
            try:
                _merge(sub_src, sub_dst)
            finally:
                os.close(sub_src)
                os.close(sub_dst)
        else:
            os.replace(entry.name, entry.name, src_dir_fd=src, dst_dir_fd=dst)


# -- the transaction -----------------------------------------------------------------------------------
_CURRENT: list[Outputs] = []


def current() -> Outputs | None:
    """The transaction of the command running now (None outside a command)."""
    return _CURRENT[-1] if _CURRENT else None


def note_read(source: str | os.PathLike[str] | int, label: str | None = None) -> None:
    """Record that the running command reads ``source`` (a path or a file descriptor): no output may replace it."""
    out = current()
    if out is not None:
        out.note_input(source, label)


class Outputs:
    """The outputs of one command, committed together (see the module text).

    ``add_stream``/``add_bytes``/``add_file``/``add_folder`` write each output's temporary at once (an
    in-place output waits for :meth:`commit`); :meth:`commit` writes the in-place ones and renames the
    rest; :meth:`abort` removes every temporary.  Use as a context manager to make it the running
    command's transaction (:func:`current`): commit on success, abort on any exception.
    """

    def __init__(self) -> None:
        self._inputs: dict[Identity, str] = {}
        self._claims: dict[Identity, list[Any]] = {}  # identity -> [label, reserved-but-unused, folder]
        self._staged: list[_Staged] = []
        self._inplace: list[tuple[Target, Callable[[BinaryIO], object]]] = []

    def __enter__(self) -> Outputs:
        _CURRENT.append(self)
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        try:
            if kind is None:
                self.commit()
            else:
                self.abort()
        finally:
            if self in _CURRENT:
                _CURRENT.remove(self)

    # -- identities ------------------------------------------------------------------------------------
    def note_input(self, source: str | os.PathLike[str] | int, label: str | None = None) -> None:
        """An input of the command: refused later as an output (or now, if an output already claimed it)."""
        if isinstance(source, int):
            ident, label = fd_identity(source), label or "standard input"
        else:
            ident, label = identity(source), label or f"the input {printable(source)}"
        if ident is None or ident[0] != "file" or ident in self._inputs:
            return  # (an input that does not exist cannot be replaced: its reader says it is missing)
        self._inputs[ident] = label
        if ident in self._claims:
            raise SameFileError(f"{self._claims[ident][0]} is the same file as {label}; refused: it would replace it")

    def reserve(self, dest: str | os.PathLike[str] | None, label: str, folder: bool = False) -> None:
        """Claim an output before the command runs (its options), so a clash is refused before any work."""
        ident = identity(dest) if dest not in (None, "-") else target(None).identity()  # type: ignore[arg-type]
        self._claim(ident, label, reserved=True, folder=folder)

    def _claim(self, ident: Identity | None, label: str, reserved: bool = False, folder: bool = False) -> None:
        if ident is None:
            return
        if ident in self._inputs:
            raise SameFileError(f"{label} is the same file as {self._inputs[ident]}; refused: it would replace it")
        prior = self._claims.get(ident)
        if prior is None:
            self._claims[ident] = [label, reserved, folder]
        elif prior[2] and folder:
            return  # two outputs into one folder: their files are checked one by one at the commit
        elif prior[1] and not reserved:
            prior[1] = False  # the reservation is used by this output
        else:
            raise SameFileError(f"{label} and {prior[0]} are the same file; refused: one would overwrite the other")

    # -- adding outputs ------------------------------------------------------------------------------------
    def add_stream(
        self, dest: str | os.PathLike[str] | None, write: Callable[[BinaryIO], object], label: str | None = None
    ) -> None:
        """An output written by ``write(fh)`` (a binary stream): to a temporary now, or in place at the commit."""
        tgt = target(dest)
        label = label or tgt.label
        self._claim(tgt.identity(), label)
        if tgt.how != "atomic":
            self._inplace.append((tgt, write))
            return
        folder, name = os.path.split(tgt.path)
        st = _Staged(label, folder, name)
        self._check_writable(st)
        fd = st.create_file()
        try:
            with os.fdopen(fd, "wb") as fh:
                write(fh)
        except OSError as exc:
            st.discard()
            raise OutputError(f"cannot write {label}: {os_reason(exc)}") from exc
        except BaseException:
            st.discard()
            raise
        self._staged.append(st)

    def add_bytes(
        self, dest: str | os.PathLike[str] | None, data: bytes | memoryview, label: str | None = None
    ) -> None:
        """An output of bytes (text, an image, HTML)."""
        self.add_stream(dest, lambda fh: fh.write(data), label)

    def add_file(
        self,
        dest: str | os.PathLike[str],
        produce: Callable[[str], T],
        *,
        suffix: str | None = None,
        label: str | None = None,
    ) -> T:
        """An output made by ``produce(path)``, a function that writes a whole file at ``path`` (a video
        writer, an image encoder); the temporary's name ends with ``suffix`` (default: ``dest``'s own, so a
        writer that picks the format by the extension picks the right one).  Returns what ``produce`` returns."""
        tgt = target(dest)
        label = label or tgt.label
        self._claim(tgt.identity(), label)
        suffix = os.path.splitext(os.fspath(dest))[1] if suffix is None else suffix
        if tgt.how != "atomic":  # made in the temporary folder, copied into the device/FIFO at the commit
            import shutil
            import tempfile

            fd, tmp = tempfile.mkstemp(suffix=suffix, prefix=".sportfusion.")
            os.close(fd)
            key = _register(None, tmp, False)
            try:
                result = produce(tmp)
            except BaseException:
                _LIVE.pop(key, None)
                _remove(None, tmp, False)
                raise

            def copy(fh: BinaryIO) -> None:
                try:
                    with open(tmp, "rb") as src:
                        shutil.copyfileobj(src, fh, 1 << 20)
                finally:
                    _LIVE.pop(key, None)
                    _remove(None, tmp, False)

            self._inplace.append((tgt, copy))
            return result
        folder, name = os.path.split(tgt.path)
        st = _Staged(label, folder, name, suffix=suffix)
        self._check_writable(st)
        os.close(st.create_file())
        try:
            result = produce(_path_in(folder, st.dfd, st.tmp))
        except OSError as exc:
            st.discard()
            raise OutputError(f"cannot write {label}: {os_reason(exc)}") from exc
        except BaseException:
            st.discard()
            raise
        self._staged.append(st)
        return result

    def add_folder(self, dest: str | os.PathLike[str], produce: Callable[[Path], T], label: str | None = None) -> T:
        """An output folder filled by ``produce(folder)`` (a temporary folder: write files into it, any
        depth); at the commit its files are moved into ``dest`` (created if it does not exist; files of the
        same name replaced, others kept).  Returns what ``produce`` returns."""
        given = os.fspath(dest)
        label = label or printable(given)
        self._claim(identity(given), label, folder=True)
        final = follow_links(given.rstrip("/") or "/")
        if os.path.isdir(final):
            st = _Staged(label, final, "", is_dir=True)
            st.merge = True
        elif os.path.lexists(final):
            raise OutputError(f"cannot write into {label}: it is not a folder")
        else:
            folder, name = os.path.split(final)
            st = _Staged(label, folder, name, is_dir=True)
        try:
            path = st.create_dir()
            from pathlib import Path

            result = produce(Path(path))
            for rel in st.produced():
                self._claim(identity(os.path.join(final, rel)), f"{label}/{printable(rel)}")
        except OSError as exc:
            st.discard()
            raise OutputError(f"cannot write into {label}: {os_reason(exc)}") from exc
        except BaseException:
            st.discard()
            raise
        self._staged.append(st)
        return result

    @staticmethod
    def _check_writable(st: _Staged) -> None:
        """Refuse to replace an existing file the shell's ``>`` could not write either."""
        try:
            os.stat(st.name, dir_fd=st.dfd)
            ok = os.access(st.name, os.W_OK, dir_fd=st.dfd)
        except (OSError, NotImplementedError):
            return  # nothing there yet (or nothing to say: the write itself will tell)
        if not ok:
            st.close()
            raise OutputError(f"cannot write {st.label}: Permission denied")

    # -- committing ----------------------------------------------------------------------------------------
    def pending(self) -> bool:
        """Whether anything waits for :meth:`commit`."""
        return bool(self._staged or self._inplace)

    def commit(self) -> None:
        """Write the in-place outputs, then rename every temporary over its destination."""
        inplace, self._inplace = self._inplace, []
        try:
            for tgt, write in inplace:
                _write_in_place(tgt, write)
        except BaseException:
            self.abort()
            raise
        staged, self._staged = self._staged, []
        done: list[str] = []
        with _Held():
            for k, st in enumerate(staged):
                try:
                    st.rename()
                    done.append(st.label)
                except OSError as exc:
                    for rest in staged[k:]:
                        rest.discard()
                    for s in staged:
                        s.close()
                    written = f" ({', '.join(done)} already replaced)" if done else ""
                    raise OutputError(f"cannot write {st.label}: {os_reason(exc)}{written}") from exc
        for st in staged:
            st.close()

    def abort(self) -> None:
        """Remove every temporary; replace nothing."""
        self._inplace = []
        staged, self._staged = self._staged, []
        for st in staged:
            st.discard()


def _write_in_place(tgt: Target, write: Callable[[BinaryIO], object]) -> None:
    """Write one output straight into standard output, an open descriptor, a device or a FIFO."""
    if tgt.how == "stdout":
        if sys.stdout is None:
            raise OutputError("cannot write standard output: it is closed; give -o FILE or redirect it")
        out = sys.stdout.buffer
        try:
            write(out)
            out.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(f"cannot write {tgt.label}: {os_reason(exc)}") from exc
        return
    try:
        fd = os.dup(tgt.fd) if tgt.how == "fd" else os.open(tgt.path, os.O_WRONLY | os.O_CLOEXEC)
    except OSError as exc:
        raise OutputError(f"cannot write {tgt.label}: {os_reason(exc)}") from exc
    try:
        with os.fdopen(fd, "wb", closefd=True) as fh:
            write(fh)
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise OutputError(f"cannot write {tgt.label}: {os_reason(exc)}") from exc
