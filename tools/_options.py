"""Option parsers shared by the tools."""

from __future__ import annotations

from collections.abc import Iterable

import click


def parse_pairs(values: Iterable[str], option: str) -> dict[str, str]:
    """``("a=1,b=2", "c=3")`` -> ``{"a": "1", "b": "2", "c": "3"}``; a usage error otherwise."""
    out: dict[str, str] = {}
    for value in values:
        for item in value.split(","):
            item = item.strip()
            if not item:
                continue
            key, sep, val = item.partition("=")
            if not sep or not key.strip() or not val.strip():
                raise click.BadParameter(f"{item!r} is not KEY=VALUE", param_hint=option)
            out[key.strip()] = val.strip()
    return out


def parse_floats(text: str, n: int, option: str) -> list[float]:
    """``"47.4,10.3,900"`` -> ``[47.4, 10.3, 900.0]`` with exactly ``n`` numbers."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} must be {n} comma-separated numbers", param_hint=option) from exc
    if len(vals) != n:
        raise click.BadParameter(f"{text!r} must be {n} comma-separated numbers", param_hint=option)
    return vals
