"""The command-line frame every sportfusion tool shares.

``@tool(name, example=...)`` turns a function into a click command with the
common behaviour of every command (README, "The tools"): INPUT defaults to stdin, ``-o FILE``, ``-v``,
``-q``, ``--version``; a terminal on stdin or stdout is refused (exit 2), so is a closed one; bad
data exits 1 with one line ``Error: <tool>: ...`` and nothing on stdout; a
closed pipe downstream is quiet.  The function receives a :class:`Tool` as its
first argument and does its reading and writing through it.

Reading and writing (the output layer, :mod:`sportfusion.core.outputs`)
-----------------------------------------------------------------------
Every output of a command is one transaction: each is written to a temporary file beside its
destination as soon as the command hands it over, and all are renamed over their destinations
together once the command body returns (the main table: when :meth:`Tool.write` is called); a failure
or a signal before that replaces nothing and removes the temporaries.  FIFOs, character devices
(``/dev/null``), ``/dev/stdout`` and ``/dev/fd/N`` are written in place; a symbolic link's target is
replaced, the link kept.  An output that is the same file (device and inode) as an input or another
output is refused before any work (exit 2, one line): the frame compares every ``click.Path`` option
(``writable=True`` = an output, otherwise an input), every option whose metavar names a ``FILE``
(``--hill NAME|FILE.toml``), INPUT or standard input, and ``-o`` or standard output; and every table read
through :func:`sportfusion.core.io.read_table` while the command runs.  So declare a new output option as
``click.Path(dir_okay=False, writable=True)`` (a folder: ``click.Path(file_okay=False, writable=True)``)
and an input as ``click.Path(...)`` without ``writable`` and it is checked with no further code.

The :class:`Tool` methods:

``tool.read(kind)`` / ``tool.read_side(path, kind, what)``
    The primary input (INPUT or stdin) / a side table (``--gates FILE``...), validated.
``tool.write(table, meta, params=None)``
    The main table to ``-o`` or stdout, with this tool's provenance step; commits every output.
``tool.write_side(path, table, meta, params=None)``
    A side table (``--truth FILE``, ``--gates FILE``, ``--holds-out FILE``), provenance added as by write.
``tool.write_bytes(data, path=None)``
    Bytes (text, HTML, an image); ``path=None``: the main output (``-o`` or stdout).
``tool.write_file(path, produce, suffix=None)``
    A file made by ``produce(temp_path)`` -- a writer that wants a file name (OpenCV's video writer,
    ``cv2.imwrite``, a ZIP writer); the temporary keeps ``path``'s extension.  Returns what produce returns.
``tool.write_folder(path, produce)``
    A folder of files made by ``produce(temp_folder)`` (``--raw DIR``: per-sensor CSV files and a mapping
    XML, a debug folder); at the commit its files move into ``path`` (created if missing; files of the same
    name replaced, others kept).  Returns what produce returns.

For example a side output ``body-model --opensense FILE.sto``::

    @click.option("--opensense", "sto_path", type=click.Path(dir_okay=False, writable=True), default=None)
    ...
    if sto_path:
        tool.write_bytes(format_sto(result).encode(), sto_path)
    tool.write(table, meta)

and ``simulate gates --raw DIR`` (``write_raw_sensors(sim, folder)`` writes the CSVs and the XML)::

    if raw_dir:
        tool.write_folder(raw_dir, lambda folder: write_raw_sensors(sim, folder))

Library code that calls :func:`sportfusion.core.io.write_table` / ``write_bytes`` with a path inside a
command joins the same transaction.  Never write an output with ``open()`` or ``Path.write_*`` directly.
"""

from __future__ import annotations

import functools
import os
import sys
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import click
import numpy as np
import pyarrow as pa

from sportfusion import __version__
from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import outputs as sfout
from sportfusion.core.errors import InputError, SameFileError
from sportfusion.core.session import drop_impossible, nonfinite_to_null
from sportfusion.data.papers import citation
from sportfusion.tools import resume_gc
from sportfusion.tools._options import check_float_options, check_option_values

T = TypeVar("T")

# OpenCV and its FFmpeg back end log to stderr from C++; a command reports problems in one line itself.
os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")


class Tool:
    """What a command body uses to read, write, report and show progress."""

    def __init__(self, name: str, source: str | None, output: str | None, verbose: bool, quiet: bool) -> None:
        self.name = name
        self.source = source
        self.output = output
        self.verbose = verbose
        self.quiet = quiet
        self.params: dict[str, Any] = {}
        self.input: pa.Table | None = None
        self.deferred: list[str] = []
        self.outputs = sfout.Outputs()

    # -- input/output -------------------------------------------------
    def read(self, kind: str | tuple[str, ...] | None = "session") -> tuple[pa.Table, dict[str, Any]]:
        """Read the primary input table (stdin unless INPUT was given) and its metadata."""
        table, meta = sfio.read_table(self.source, kind=kind)
        if meta["kind"] in ("session", "truth"):
            table, dropped = drop_impossible(table)
            if dropped:  # said once the command succeeds (a failure says one line only)
                self.deferred.append(
                    f"{sum(dropped.values())} NaN/inf or physically impossible sensor value(s) in "
                    f"{', '.join(sorted(dropped))} read as missing"
                )
        if self.input is None:
            self.input = table
        return table, meta

    def read_side(
        self, path: str | os.PathLike[str], kind: str | tuple[str, ...] | None, what: str | None = None
    ) -> tuple[pa.Table, dict[str, Any]]:
        """Read a side table (``--gates FILE``, ``--truth FILE``...) and its metadata, validated as ``kind``;
        no output of this command may replace it."""
        return sfio.read_table(path, kind=kind, what=what)

    def write(self, table: pa.Table, meta: dict[str, Any], params: dict[str, Any] | None = None) -> None:
        """Append this tool's provenance step and write the table (complete before the encoder writes it) to
        ``-o`` or stdout; then commit every output of the command (side outputs too).

        NaN/inf in a column this tool made (an estimate) is written as null, counted on stderr.
        """
        if self.input is None and meta.get("kind") in ("session", "truth"):  # a reader (ingest): same rule
            table, dropped = drop_impossible(table)
            if dropped:
                self.warn(
                    f"{sum(dropped.values())} NaN/inf or physically impossible sensor value(s) in "
                    f"{', '.join(sorted(dropped))} written as missing"
                )
            if meta.get("kind") == "session":
                from sportfusion.core.timeunit import check_time_unit

                check_time_unit(table, "the session read")
        table, counts = nonfinite_to_null(table, _unchanged(self.input, table))
        if counts:
            worst = max(counts.values())
            self.info(f"{worst} row(s) have no finite estimate in {', '.join(sorted(counts))}: written as null")
        step = dict(self.params if params is None else params)
        encode = sfio.table_writer(table, sfmeta.add_provenance(meta, self.name, step))  # encoded into the output
        self.outputs.add_stream(self.output, encode, self._main_label())
        self.commit()

    def write_side(
        self,
        path: str | os.PathLike[str],
        table: pa.Table,
        meta: dict[str, Any],
        params: dict[str, Any] | None = None,
    ) -> None:
        """A side table (``--truth FILE``...) with this tool's provenance step, committed with the main output."""
        step = dict(self.params if params is None else params)
        self.outputs.add_stream(path, sfio.table_writer(table, sfmeta.add_provenance(meta, self.name, step)))

    def write_bytes(self, data: bytes | memoryview, path: str | os.PathLike[str] | None = None) -> None:
        """Bytes to ``path``, or with ``path=None`` to the main output (``-o`` or stdout); committed with the rest."""
        if path is None:
            self.outputs.add_bytes(self.output, data, self._main_label())
        else:
            self.outputs.add_bytes(path, data)

    def write_file(self, path: str | os.PathLike[str], produce: Callable[[str], T], suffix: str | None = None) -> T:
        """A file made by ``produce(temp_path)`` (see the module text); returns what ``produce`` returns."""
        return self.outputs.add_file(path, produce, suffix=suffix)

    def write_folder(self, path: str | os.PathLike[str], produce: Callable[[Path], T]) -> T:
        """A folder of files made by ``produce(temp_folder)`` (see the module text); returns what it returns."""
        return self.outputs.add_folder(path, produce)

    def commit(self) -> None:
        """Commit every output handed over so far (the frame does it when the command body returns)."""
        self.outputs.commit()

    def _main_label(self) -> str:
        return "standard output" if self.output in (None, "-") else f"-o {sfout.printable(str(self.output))}"

    # -- messages -----------------------------------------------------
    def info(self, message: str) -> None:
        """A progress/info line on stderr (silenced by -q)."""
        if not self.quiet:
            click.echo(f"{self.name}: {message}", err=True)

    def warn(self, message: str) -> None:
        """A warning on stderr (always shown)."""
        click.echo(f"Warning: {self.name}: {message}", err=True)

    def progress(self, iterable: Iterable[T], length: int | None = None, label: str = "") -> Iterator[T]:
        """Iterate with a click progress bar on stderr when stderr is a terminal and not -q."""
        if self.quiet or not sys.stderr.isatty():
            yield from iterable
            return
        with click.progressbar(iterable, length=length, label=label or self.name, file=sys.stderr) as bar:
            yield from bar


def _unchanged(source: pa.Table | None, table: pa.Table) -> set[str]:
    """Float columns of ``table`` passed through unchanged from ``source`` (NaN equal to NaN)."""
    if source is None or source.num_rows != table.num_rows:
        return set()
    keep = set()
    for name in set(source.column_names) & set(table.column_names):
        a, b = source.column(name), table.column(name)
        if a.type != b.type or not pa.types.is_floating(a.type):
            continue
        if _same_buffers(a, b) or np.array_equal(
            a.to_numpy(zero_copy_only=False), b.to_numpy(zero_copy_only=False), equal_nan=True
        ):
            keep.add(name)
    return keep


def _same_buffers(a: pa.ChunkedArray, b: pa.ChunkedArray) -> bool:
    """Whether two columns are the very same memory (a pass-through), without comparing values."""
    if a.num_chunks != b.num_chunks:
        return False
    for x, y in zip(a.chunks, b.chunks, strict=True):
        if x.offset != y.offset or len(x) != len(y):
            return False
        bx, by = x.buffers(), y.buffers()
        if len(bx) != len(by) or any(
            (p is None) != (q is None) or (p is not None and p.address != q.address)
            for p, q in zip(bx, by, strict=True)
        ):
            return False
    return True


def _refuse(name: str, message: str) -> None:
    """A usage problem the frame finds before the command runs: one line, exit 2."""
    click.echo(f"Error: {name}: {message}", err=True)
    sys.exit(2)


def _raw_values(source: Any, output: Any, kwargs: dict[str, Any]) -> list[str]:
    """The option values (paths) with characters a message line cannot show as they are (a newline)."""
    out = []
    for v in (source, output, *kwargs.values()):
        for item in v if isinstance(v, (tuple, list)) else (v,):
            if isinstance(item, (str, os.PathLike)):
                text = os.fspath(item)
                if isinstance(text, str) and text and not text.isprintable():
                    out.append(text)
    return sorted(out, key=len, reverse=True)


def _clean(message: str, raw: list[str]) -> str:
    """One line of ``message``: known paths with control characters escaped first, then every other
    unprintable character (a binary file's bytes quoted in a message)."""
    for text in raw:
        message = message.replace(text, sfout.printable(text))
    return sfout.printable(one_line(message))


def _claim_paths(t: Tool, cmd: click.Command, kwargs: dict[str, Any], reads_table: bool, to_stdout: bool) -> None:
    """Note the command's inputs and reserve its outputs (options, INPUT, -o, stdin, stdout) before it runs,
    so an output that is an input or another output is refused before any work (SameFileError)."""
    out = t.outputs
    if reads_table:
        if t.source in (None, "-"):
            fd = sfout.stream_fd(sys.stdin)
            if fd is not None:
                out.note_input(fd, "standard input")
        else:
            out.note_input(t.source, f"the input {sfout.printable(str(t.source))}")
    main_given = False
    for p in cmd.params:
        if p.name in (None, "input", "verbose", "quiet") or p.name not in kwargs and p.name != "output":
            continue
        value = t.output if p.name == "output" and p.name not in kwargs else kwargs.get(p.name)
        values = value if isinstance(value, (tuple, list)) else (value,)
        opt = max(p.opts, key=len) if isinstance(p, click.Option) else None
        for v in values:
            if v is None or v == "-" or v == "" or not isinstance(v, (str, os.PathLike)):
                continue
            text = sfout.printable(os.fspath(v))
            label = f"{'-o' if p.name == 'output' else opt} {text}" if opt else f"the input {text}"
            if isinstance(p.type, click.Path) and p.type.writable:
                out.reserve(v, label, folder=not p.type.file_okay)
                main_given = main_given or p.name == "output"
            elif isinstance(p.type, click.Path):
                out.note_input(v, label)
            elif "FILE" in (getattr(p, "metavar", None) or "") and os.path.isfile(v):
                out.note_input(v, label)
    if to_stdout and not main_given:
        out.reserve(None, "standard output")


def one_line(message: str, limit: int = 400) -> str:
    """The first non-empty line of ``message`` (a pyarrow schema dump or a warning list is cut off)."""
    lines = [ln.strip() for ln in message.splitlines() if ln.strip()]
    text = lines[0] if lines else message.strip()
    if len(lines) > 1 and text.endswith(":"):  # "...: schema:\n a: double" -> keep the headline only
        text = text[:-1]
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return text


#: Warning categories that only concern developers (never shown to the user).
_SILENT = (DeprecationWarning, PendingDeprecationWarning, FutureWarning, ImportWarning, ResourceWarning)


def _report_warnings(tool: Tool, caught: list[warnings.WarningMessage]) -> None:
    """Translate the numerical warnings raised under a command into one line; drop the rest."""
    numeric = [w for w in caught if not issubclass(w.category, _SILENT)]
    if numeric:
        first = one_line(str(numeric[0].message), 160)
        more = f" (and {len(numeric) - 1} more)" if len(numeric) > 1 else ""
        tool.info(f"numerical warning from the computation: {first}{more}; results were checked for NaN/inf")


def _is_tty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _quiet_broken_pipe() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _console_exit_code(exc: SystemExit) -> int:
    if exc.code is None:
        return 0
    if isinstance(exc.code, int):
        return exc.code
    click.echo(str(exc.code), err=True)
    return 1


class _NoPandas:
    """Import finder that refuses pandas (see :class:`CleanExit`)."""

    @staticmethod
    def find_spec(name: str, path: Any = None, target: Any = None) -> None:
        if name == "pandas" or name.startswith("pandas."):
            raise ImportError("pandas is kept out of sportfusion's commands (none uses it)")


class CleanExit:
    """Mixin for click commands and groups run as console scripts: exit with ``os._exit``.

    pyarrow's C++ thread pools are sometimes still being torn down when the interpreter finalises,
    and the process then dies with ``terminate called without an active exception`` (SIGABRT) after
    its work was done and written (apache/arrow#34314). A console script therefore flushes its
    streams and leaves through ``os._exit`` with click's exit code, skipping that teardown. Run any
    other way (click's test runner, ``standalone_mode=False``, ``python -m``) the command behaves as
    a plain click command.

    A console script also keeps pandas out: no command uses it, but where it is installed pyarrow
    imports it on the first ``to_numpy`` of a column (its optional pandas integration), which costs a
    command 0.13-0.25 s of CPU before any work (measured on rts-smooth, issue 18).

    However it is run, the command first turns Python's garbage collector back on where the console
    script's imports paused it (:func:`sportfusion.tools.resume_gc`).
    """

    def main(self, *args: Any, **kwargs: Any) -> Any:
        resume_gc()  # paused while a console script's modules imported (sportfusion.tools)
        as_script = kwargs.get("standalone_mode", True) and os.path.basename(sys.argv[0]) == self.name  # type: ignore[attr-defined]
        if not as_script:
            return super().main(*args, **kwargs)  # type: ignore[misc]
        if "pandas" not in sys.modules:
            sys.meta_path.insert(0, _NoPandas)  # type: ignore[arg-type]  # pyarrow then treats pandas as absent
        try:
            super().main(*args, **kwargs)  # type: ignore[misc]
            code = 0
        except SystemExit as exc:
            code = _console_exit_code(exc)
        for stream in (sys.stdout, sys.stderr):
            try:
                if stream is not None:
                    stream.flush()
            except BrokenPipeError:
                code = code or 1
            except (OSError, ValueError) as exc:
                if stream is sys.stdout:
                    code = code or 1
                    why = getattr(exc, "strerror", None) or type(exc).__name__
                    try:
                        sys.stderr.write(f"Error: {self.name}: cannot write standard output: {why}\n")  # type: ignore[attr-defined]
                        sys.stderr.flush()
                    except (AttributeError, OSError, ValueError):
                        pass
        os._exit(code)


class Command(CleanExit, click.Command):
    """A click command that exits cleanly as a console script (see :class:`CleanExit`)."""


class Group(CleanExit, click.Group):
    """A click group that exits cleanly as a console script (see :class:`CleanExit`)."""


class OutputPath(click.Path):
    """``click.Path(writable=True)`` that lets an open descriptor's name through (``/dev/stdout``, ``/dev/fd/N``,
    ``/proc/self/fd/N``): the output layer writes the descriptor itself, which may be writable where
    reopening its name is not (a file the shell opened for another user)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and value.startswith("/") and sfout.target_is_descriptor(value):
            return value
        return super().convert(value, param, ctx)


def _output_paths(cmd: click.Command) -> None:
    """Give every writable ``click.Path`` option of ``cmd`` the :class:`OutputPath` type."""
    for p in cmd.params:
        t = p.type
        if isinstance(t, click.Path) and t.writable and not isinstance(t, OutputPath):
            new = OutputPath(
                exists=t.exists,
                file_okay=t.file_okay,
                dir_okay=t.dir_okay,
                writable=True,
                readable=t.readable,
                resolve_path=t.resolve_path,
                allow_dash=t.allow_dash,
                path_type=t.type,
                executable=getattr(t, "executable", False),
            )
            p.type = new


def papers_epilog(cites: tuple[str, ...]) -> str:
    """Help-text paragraphs citing the papers ``cites`` (short names) in full; empty when none."""
    if not cites:
        return ""
    refs = "\n\n".join(f"[{k}] {citation(k)}" for k in cites)
    return f"Papers (short names used above):\n\n{refs}\n\n"


def tool(
    name: str,
    *,
    example: str,
    reads_table: bool = True,
    writes_table: bool = True,
    stdout: bool | None = None,
    input_help: str = "Input table (Parquet); default: standard input.",
    cites: tuple[str, ...] = (),
) -> Callable[[Callable[..., None]], click.Command]:
    """Decorator: build a sportfusion click command around ``func(tool, **options)``.

    Parameters
    ----------
    name : str
        Command name used in messages and provenance.
    example : str
        Worked example appended to ``--help``.
    reads_table : bool
        Add the optional INPUT argument (default stdin) and refuse a terminal on stdin.
    writes_table : bool
        Add ``-o/--output`` and refuse a terminal on stdout.
    stdout : bool, optional
        Whether the command writes to standard output when it is given no ``-o`` (default: ``writes_table``;
        ``inspect`` and ``evaluate`` write text there): a closed standard output is then refused (exit 2),
        and standard output may not be the same file as an input.
    cites : tuple of str
        Short names of the papers the command implements (keys of
        :data:`sportfusion.data.papers.PAPERS`); their full citations end the help.
    """
    to_stdout = writes_table if stdout is None else stdout

    def decorate(func: Callable[..., None]) -> click.Command:
        @functools.wraps(func)
        def body(**kwargs: Any) -> None:
            source = kwargs.pop("input", None) if reads_table else None
            output = kwargs.pop("output", None) if writes_table else None
            verbose = kwargs.pop("verbose")
            quiet = kwargs.pop("quiet")
            if reads_table and source in (None, "-"):
                if sys.stdin is None:
                    _refuse(name, "standard input is closed; give INPUT or pipe a table in")
                if _is_tty(sys.stdin):
                    raise click.UsageError("standard input is a terminal; pipe a Parquet table in or give INPUT")
            main_out = output if writes_table else kwargs.get("output")
            has_o = writes_table or "output" in kwargs
            if to_stdout and main_out in (None, "-"):
                if sys.stdout is None:
                    _refuse(name, f"standard output is closed; redirect it{' or give -o FILE' if has_o else ''}")
                if writes_table and _is_tty(sys.stdout):
                    raise click.UsageError("standard output is a terminal; redirect it or give -o FILE")
            if output not in (None, "-"):
                folder = os.path.dirname(output) or "."
                if not os.path.isdir(folder):
                    raise click.BadParameter(
                        f"the folder {sfout.printable(folder)} does not exist", param_hint="-o/--output"
                    )
            ctx = click.get_current_context()
            check_option_values(ctx.command, kwargs)
            t = Tool(name, source, output, verbose, quiet)
            t.params = {k: v for k, v in kwargs.items()}
            raw_names = _raw_values(source, output, kwargs)
            try:
                # NaN/inf results are nulled and counted at write time; numpy's own warnings are noise
                with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"), t.outputs:
                    warnings.simplefilter("always")
                    _claim_paths(t, ctx.command, kwargs, reads_table, to_stdout)
                    func(t, **kwargs)
                _report_warnings(t, caught)
                for message in t.deferred:
                    t.warn(message)
            except SameFileError as exc:
                click.echo(f"Error: {name}: {_clean(str(exc), raw_names)}", err=True)
                sys.exit(2)
            except InputError as exc:
                click.echo(f"Error: {name}: {_clean(str(exc), raw_names)}", err=True)
                if verbose:
                    traceback.print_exc()
                sys.exit(1)
            except MemoryError as exc:
                click.echo(
                    f"Error: {name}: not enough memory for this input ({_clean(str(exc), raw_names) or 'MemoryError'}); "
                    "expected a smaller input or more memory",
                    err=True,
                )
                sys.exit(1)
            except BrokenPipeError:
                _quiet_broken_pipe()
                sys.exit(1)
            except (click.ClickException, click.exceptions.Exit, click.Abort, KeyboardInterrupt, SystemExit):
                raise
            except RecursionError as exc:
                click.echo(
                    f"Error: {name}: the input is nested too deeply to process ({_clean(str(exc), raw_names)})",
                    err=True,
                )
                sys.exit(1)
            except OSError as exc:  # the system refused something (a full disk, a file that went away): say what
                where = f" ({sfout.printable(exc.filename)})" if getattr(exc, "filename", None) else ""
                click.echo(f"Error: {name}: {exc.strerror or type(exc).__name__}{where}", err=True)
                if verbose:
                    traceback.print_exc()
                sys.exit(1)
            except Exception as exc:  # an unexpected exception is a bug: say so, one line
                click.echo(
                    f"Error: {name}: internal error {type(exc).__name__}: {_clean(str(exc), raw_names)} "
                    "(this is a bug; run with -v for the traceback)",
                    err=True,
                )
                if verbose:
                    traceback.print_exc()
                sys.exit(1)

        doc = (func.__doc__ or "").strip()
        epilog = papers_epilog(cites) + "\b\nExample:\n" + example.strip("\n")
        cmd = click.command(name=name, cls=Command, help=doc, epilog=epilog)(body)
        check_float_options(cmd)
        cmd = click.version_option(
            __version__, "--version", prog_name=name, message="%(prog)s (sportfusion) %(version)s"
        )(cmd)
        cmd = click.option("-q", "--quiet", is_flag=True, help="No progress or info on stderr.")(cmd)
        cmd = click.option("-v", "--verbose", is_flag=True, help="Show the traceback on errors.")(cmd)
        if writes_table:
            cmd = click.option(
                "-o",
                "--output",
                type=click.Path(dir_okay=False, writable=True),
                default=None,
                help="Output table (Parquet), written atomically; default: standard output.",
            )(cmd)
        if reads_table:
            cmd.params.insert(
                0, click.Argument(["input"], required=False, type=click.Path(dir_okay=False, allow_dash=True))
            )
            cmd.params[0].help = input_help  # type: ignore[attr-defined]
        _output_paths(cmd)
        return cmd

    return decorate
