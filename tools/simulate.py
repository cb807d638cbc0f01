"""``simulate``: truth and noisy sensor sessions for each sport (one subcommand per sport).

Each subcommand lives in ``tools/simulate_<sport>.py`` as a ``@tool(...,
reads_table=False)`` command named ``simulate <sport>`` and is added below.
"""

from __future__ import annotations

import click

from sportfusion import __version__
from sportfusion.tools._cli import Group


@click.group(
    cls=Group,
    name="simulate",
    epilog="\b\nExample:\n  simulate <sport> --seed 1 --truth truth.parquet > session.parquet",
)
@click.version_option(__version__, "--version", prog_name="simulate", message="%(prog)s (sportfusion) %(version)s")
def main() -> None:
    """Simulate a session with known truth: the session table on stdout, the
    truth (and the venue: hill, holds, gates) in side files. Reads nothing."""


# Subcommands (each helper adds one line here):
main.add_command(__import__("sportfusion.tools.simulate_skirace", fromlist=["main"]).main, "skirace")
main.add_command(__import__("sportfusion.tools.simulate_skijump", fromlist=["main"]).main, "skijump")
main.add_command(__import__("sportfusion.tools.simulate_boulder", fromlist=["main"]).main, "boulder")
main.add_command(__import__("sportfusion.tools.simulate_gates", fromlist=["main"]).main, "gates")
