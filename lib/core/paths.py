"""Paths of outputs: what a name refers to, its identity (device and inode), and how to show it in a message.

Used by the output layer (:mod:`sportfusion.core.outputs`); see its text for the rules.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import sys
from typing import Any

from sportfusion.core.errors import OutputError

#: Longest file name (bytes) the temporary names are kept within (Linux NAME_MAX).
NAME_MAX = 255
_FD_PATH = re.compile(
    r"/(?:dev/(?P<std>stdin|stdout|stderr)|dev/fd/(?P<dev>\d+)|proc/(?P<pid>self|thread-self|\d+)/fd/(?P<proc>\d+))"
)
_STD = {"stdin": 0, "stdout": 1, "stderr": 2}

#: An identity: ("file", st_dev, st_ino) of an existing file, ("new", st_dev, st_ino of the folder, name)
#: of a name that does not exist yet.
Identity = tuple[Any, ...]


# -- messages ----------------------------------------------------------------------------------------
def printable(text: str | bytes | os.PathLike[str]) -> str:
    """``text`` with control characters, undecodable bytes and other unprintables escaped (``\\n``, ``\\x89``).

    A file name with a newline or a binary byte in it stays on one line and shows what it is.
    """
    if isinstance(text, bytes):
        text = text.decode("utf-8", "surrogateescape")
    text = os.fspath(text) if not isinstance(text, str) else text
    if text.isprintable():
        return text
    out = []
    for c in text:
        if c.isprintable():
            out.append(c)
        elif 0xDC80 <= ord(c) <= 0xDCFF:  # an undecodable byte (surrogateescape)
            out.append(f"\\x{ord(c) - 0xDC00:02x}")
        else:
            out.append(c.encode("unicode_escape").decode("ascii"))
    return "".join(out)


def os_reason(exc: OSError) -> str:
    why = printable(exc.strerror or str(exc) or type(exc).__name__)
    if getattr(exc, "errno", None) == errno.ENAMETOOLONG:
        why += f" (at most {NAME_MAX} bytes a file name, 4096 a path)"
    return why


# -- identities --------------------------------------------------------------------------------------
def follow_links(path: str) -> str:
    """``path`` with the symbolic links of its last component followed (not the folders': the kernel does)."""
    p = path
    for _ in range(40):
        try:
            st = os.lstat(p)
        except OSError:
            return p
        if not stat.S_ISLNK(st.st_mode):
            return p
        link = os.readlink(p)
        p = link if link.startswith("/") else os.path.join(os.path.dirname(p), link)
    return p


def _of_stat(st: os.stat_result) -> Identity | None:
    if stat.S_ISCHR(st.st_mode):
        return None  # /dev/null, a terminal: may be named any number of times
    return ("file", st.st_dev, st.st_ino)


def identity(path: str | os.PathLike[str]) -> Identity | None:
    """The identity of the file ``path`` names (through links); None for a character device or an unusable path."""
    p = os.fspath(path)
    try:
        return _of_stat(os.stat(p))
    except FileNotFoundError:
        final = follow_links(p)
        folder, name = os.path.split(final)
        try:
            st = os.stat(folder or ".")
        except OSError:
            return None
        return ("new", st.st_dev, st.st_ino, name)
    except (OSError, ValueError):
        return None


def fd_identity(fd: int) -> Identity | None:
    """The identity of an open file descriptor (None: closed, or a character device)."""
    try:
        return _of_stat(os.fstat(fd))
    except (OSError, ValueError):
        return None


def stream_fd(stream: Any) -> int | None:
    """The file descriptor behind a standard stream, or None (closed, or a test runner's in-memory stream)."""
    try:
        return int(stream.fileno())
    except (AttributeError, ValueError, OSError):
        return None


# -- where an output goes ----------------------------------------------------------------------------
class Target:
    """How one output is written: ``stdout``, ``fd`` (an open descriptor), ``inplace`` (a device, a FIFO)
    or ``atomic`` (a temporary file renamed over ``path``)."""

    def __init__(self, label: str, how: str, path: str = "", fd: int = -1) -> None:
        self.label, self.how, self.path, self.fd = label, how, path, fd

    def identity(self) -> Identity | None:
        if self.how == "stdout":
            fd = stream_fd(sys.stdout)
            return None if fd is None else fd_identity(fd)
        if self.how == "fd":
            return fd_identity(self.fd)
        return identity(self.path)


def target_is_descriptor(path: str) -> bool:
    """Whether ``path`` names an open descriptor of this process (``/dev/stdout``, ``/dev/fd/N``, ``/proc/self/fd/N``)."""
    m = _FD_PATH.fullmatch(os.path.normpath(path)) if path.startswith("/") else None
    return m is not None and m["pid"] in (None, "self", "thread-self", str(os.getpid()))


def target(dest: str | os.PathLike[str] | None) -> Target:
    """Where ``dest`` (a path; None or ``"-"``: standard output) is written, following its symbolic links.

    Raises
    ------
    OutputError
        A folder, a block device or a socket, a loop of links, or a path that cannot be looked at.
    """
    if dest is None or dest == "-":
        return Target("standard output", "stdout")
    given = os.fspath(dest)
    label = printable(given)
    p = given
    for _ in range(40):
        m = _FD_PATH.fullmatch(os.path.normpath(p)) if p.startswith("/") else None
        if m is not None:
            fd = _STD[m["std"]] if m["std"] else int(m["dev"] or m["proc"])
            if m["pid"] not in (None, "self", "thread-self", str(os.getpid())):
                return Target(label, "inplace", path=p)  # another process's descriptor: opened by its name
            return Target(label, "stdout") if fd == 1 else Target(label, "fd", fd=fd)
        try:
            st = os.lstat(p)
        except FileNotFoundError:
            return Target(label, "atomic", path=p)  # a new file (or the target of a dangling link)
        except OSError as exc:
            raise OutputError(f"cannot write {label}: {os_reason(exc)}") from exc
        if not stat.S_ISLNK(st.st_mode):
            break
        link = os.readlink(p)
        p = link if link.startswith("/") else os.path.join(os.path.dirname(p), link)
    else:
        raise OutputError(f"cannot write {label}: too many levels of symbolic links")
    mode = st.st_mode
    if stat.S_ISREG(mode):
        return Target(label, "atomic", path=p)
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return Target(label, "inplace", path=p)
    what = "a folder" if stat.S_ISDIR(mode) else "a block device" if stat.S_ISBLK(mode) else "a socket"
    raise OutputError(f"cannot write {label}: it is {what}; expected a file name, a FIFO or a character device")
