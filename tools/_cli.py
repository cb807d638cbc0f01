"""The command-line frame every sportfusion tool shares.

``@tool(name, example=...)`` turns a function into a click command with the
common behaviour of DESIGN.md: INPUT defaults to stdin, ``-o FILE``, ``-v``,
``-q``, ``--version``; a terminal on stdin or stdout is refused (exit 2); bad
data exits 1 with one line ``Error: <tool>: ...`` and nothing on stdout; a
closed pipe downstream is quiet.  The function receives a :class:`Tool` as its
first argument and does its reading and writing through it.
"""

from __future__ import annotations

import functools
import os
import sys
import traceback
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

import click
import pyarrow as pa

from sportfusion import __version__
from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.tools._options import check_float_options, check_option_values

T = TypeVar("T")


class Tool:
    """What a command body uses to read, write, report and show progress."""

    def __init__(self, name: str, source: str | None, output: str | None, verbose: bool, quiet: bool) -> None:
        self.name = name
        self.source = source
        self.output = output
        self.verbose = verbose
        self.quiet = quiet
        self.params: dict[str, Any] = {}

    # -- input/output -------------------------------------------------
    def read(self, kind: str | tuple[str, ...] | None = "session") -> tuple[pa.Table, dict[str, Any]]:
        """Read the primary input table (stdin unless INPUT was given) and its metadata."""
        return sfio.read_table(self.source, kind=kind)

    def write(self, table: pa.Table, meta: dict[str, Any], params: dict[str, Any] | None = None) -> None:
        """Append this tool's provenance step and write the table (built whole, then written)."""
        step = dict(self.params if params is None else params)
        data = sfio.table_to_bytes(table, sfmeta.add_provenance(meta, self.name, step))
        sfio.write_bytes(data, self.output)

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


class CleanExit:
    """Mixin for click commands and groups run as console scripts: exit with ``os._exit``.

    pyarrow's C++ thread pools are sometimes still being torn down when the interpreter finalises,
    and the process then dies with ``terminate called without an active exception`` (SIGABRT) after
    its work was done and written (apache/arrow#34314). A console script therefore flushes its
    streams and leaves through ``os._exit`` with click's exit code, skipping that teardown. Run any
    other way (click's test runner, ``standalone_mode=False``, ``python -m``) the command behaves as
    a plain click command.
    """

    def main(self, *args: Any, **kwargs: Any) -> Any:
        as_script = kwargs.get("standalone_mode", True) and os.path.basename(sys.argv[0]) == self.name  # type: ignore[attr-defined]
        if not as_script:
            return super().main(*args, **kwargs)  # type: ignore[misc]
        try:
            super().main(*args, **kwargs)  # type: ignore[misc]
            code = 0
        except SystemExit as exc:
            code = _console_exit_code(exc)
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                if stream is sys.stdout:
                    code = code or 1
        os._exit(code)


class Command(CleanExit, click.Command):
    """A click command that exits cleanly as a console script (see :class:`CleanExit`)."""


class Group(CleanExit, click.Group):
    """A click group that exits cleanly as a console script (see :class:`CleanExit`)."""


def tool(
    name: str,
    *,
    example: str,
    reads_table: bool = True,
    writes_table: bool = True,
    input_help: str = "Input table (Parquet); default: standard input.",
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
    """

    def decorate(func: Callable[..., None]) -> click.Command:
        @functools.wraps(func)
        def body(**kwargs: Any) -> None:
            source = kwargs.pop("input", None) if reads_table else None
            output = kwargs.pop("output", None) if writes_table else None
            verbose = kwargs.pop("verbose")
            quiet = kwargs.pop("quiet")
            if reads_table and source in (None, "-") and _is_tty(sys.stdin):
                raise click.UsageError("standard input is a terminal; pipe a Parquet table in or give INPUT")
            if writes_table and output in (None, "-") and _is_tty(sys.stdout):
                raise click.UsageError("standard output is a terminal; redirect it or give -o FILE")
            check_option_values(click.get_current_context().command, kwargs)
            t = Tool(name, source, output, verbose, quiet)
            t.params = {k: v for k, v in kwargs.items()}
            try:
                func(t, **kwargs)
            except InputError as exc:
                click.echo(f"Error: {name}: {exc}", err=True)
                if verbose:
                    traceback.print_exc()
                sys.exit(1)
            except BrokenPipeError:
                _quiet_broken_pipe()
                sys.exit(1)
            except (click.ClickException, click.exceptions.Exit, click.Abort, KeyboardInterrupt, SystemExit):
                raise
            except Exception as exc:  # an unexpected exception is a bug: say so, one line
                click.echo(
                    f"Error: {name}: internal error {type(exc).__name__}: {exc} "
                    "(this is a bug; run with -v for the traceback)",
                    err=True,
                )
                if verbose:
                    traceback.print_exc()
                sys.exit(1)

        doc = (func.__doc__ or "").strip()
        cmd = click.command(name=name, cls=Command, help=doc, epilog="\b\nExample:\n" + example.strip("\n"))(body)
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
        return cmd

    return decorate
