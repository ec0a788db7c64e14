"""Every default of the fleet.toml sections is written down where users read it, with its
value: docs/design.md's reference table has a row for each settings field, and the README's
reference file shows each one of [alerts], [nightly] and [schedule] at its default."""
from __future__ import annotations

import dataclasses
import pathlib
import re
import tomllib

import pytest

from flows.config.settings import (AlertSettings, DaskSettings, NightlySettings,
                                   NotificationSettings, ScheduleSettings)
from flows.memory import parse_bytes

ROOT = pathlib.Path(__file__).resolve().parents[2]
SECTIONS = {"alerts": AlertSettings, "nightly": NightlySettings, "dask": DaskSettings,
            "schedule": ScheduleSettings, "notifications": NotificationSettings}
#: README sections whose reference file shows the defaults (dask and notifications show examples)
README_SECTIONS = ("alerts", "nightly", "schedule")


def _comparable(section: str, name: str, value):
    if name == "memory_budget" and isinstance(value, str):
        return parse_bytes(value)
    if isinstance(value, pathlib.Path):
        return str(value)
    return value


def _defaults(section: str) -> dict:
    return {f.name: _comparable(section, f.name, f.default)
            for f in dataclasses.fields(SECTIONS[section])}


def _design_rows() -> dict[str, object]:
    rows = {}
    text = (ROOT / "docs" / "design.md").read_text()
    for key, cell in re.findall(r"^\| `([a-z_]+\.[a-z_]+)` \| ([^|]+) \|", text, re.MULTILINE):
        literal = re.match(r"`([^`]+)`", cell.strip())
        rows[key] = (tomllib.loads(f"v = {literal.group(1)}")["v"] if literal
                     else None if cell.strip().startswith("none") else cell.strip())
    return rows


@pytest.mark.parametrize("section", sorted(SECTIONS))
def test_design_md_has_every_default_with_its_value(section):
    rows = _design_rows()
    for name, default in _defaults(section).items():
        key = f"{section}.{name}"
        assert key in rows, f"docs/design.md's fleet.toml table has no row for {key}"
        assert _comparable(section, name, rows[key]) == default, key


@pytest.mark.parametrize("section", README_SECTIONS)
def test_readme_reference_file_shows_every_default(section):
    text = (ROOT / "README.md").read_text()
    block = text[text.index("## Configuration reference"):]
    block = block[block.index("```toml") + len("```toml"):]
    reference = tomllib.loads(block[:block.index("```")])
    shown = {name: _comparable(section, name, value)
             for name, value in reference[section].items()}
    assert shown == _defaults(section)
