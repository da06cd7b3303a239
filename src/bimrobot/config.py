"""Reading configuration files (fleets, sites, capability tables, scenarios)."""

from __future__ import annotations

from typing import Any

import yaml

from bimrobot.errors import InputError


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML ``text``; a syntax error becomes an InputError naming ``source`` and the line."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        raise InputError(f"{source}{where}: not valid YAML ({getattr(exc, 'problem', None) or exc})") from None
