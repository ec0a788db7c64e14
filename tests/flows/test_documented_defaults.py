"""Every key of fleet.toml is documented once, in docs/configuration.md, with the default the
parser applies.

The page's tables are generated from the settings' dataclasses (``python -m
flows.config.reference``); these tests check the committed page against the generator, and
check the page on its own terms, read back as a user reads it: its keys are exactly the keys
the parser accepts in every table (top level, each section, a class, its ``settings``,
``settings.network`` and ``grid``), a file written from its documented defaults loads to the
same configuration as a file that leaves them all out, a key documented "none" is None or
empty when left out, and a "required" one is refused when missing.
"""
from __future__ import annotations

import pathlib
import re
import tomllib

import pytest

from flows.config import ConfigError, parse_config
from flows.config.reference import PAGE, generate, page_section, write

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLASS = "classes.<name>"
MODEL = "graybox.models:GasTurbineShaft"
MINIMAL = {"classes": {"turbine": {"model": MODEL, "assets": ["T-*"]}}}


def _rows() -> dict[str, str]:
    """Documented key -> its default cell, from the page's tables."""
    text = PAGE.read_text()
    rows = re.findall(r"^\| `([a-z_.<>]+)` \| ([^|]+) \|", page_section(text), re.MULTILINE)
    keys = [key for key, _ in rows]
    assert len(keys) == len(set(keys)), "a key is documented twice"
    return {key: cell.strip() for key, cell in rows}


def _value(cell: str):
    """A documented default as TOML reads it (None for "none" and "required")."""
    if cell in ("none", "required"):
        return None
    literal = re.fullmatch(r"`([^`]+)`", cell)
    assert literal, f"a default must be `<toml value>`, none or required, got {cell!r}"
    return tomllib.loads(f"v = {literal.group(1)}")["v"]


def _parse(data: dict, tmp_path: pathlib.Path):
    return parse_config(data, tmp_path / "fleet.toml")


def _nest(data: dict, key: str, value) -> None:
    *tables, name = key.replace(CLASS, "classes.turbine").split(".")
    for table in tables:
        data = data.setdefault(table, {})
    data[name] = value


def _accepted(where: str, tmp_path) -> list[str]:
    """The keys the parser accepts at a dotted table, from its refusal of an unknown one."""
    data = {"classes": {"turbine": {"model": MODEL, "assets": ["T-*"]}}}
    _nest(data, f"{where}.not_a_key" if where else "not_a_key", 1)
    with pytest.raises(ConfigError) as error:
        _parse(data, tmp_path)
    known = re.search(r"(?:expected one of|known:) (.*)$", str(error.value)).group(1)
    return known.split(", ")


def test_the_page_holds_the_generated_reference():
    assert page_section(PAGE.read_text()) == generate(), \
        "docs/configuration.md is out of date: run python -m flows.config.reference --write"


def test_write_puts_the_generated_reference_between_the_markers(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE.read_text().replace(page_section(PAGE.read_text()),
                                             page_section(PAGE.read_text()).replace("`2`", "`1`")))
    assert write(page) and page_section(page.read_text()) == generate()
    assert not write(page)


TABLES = ("", "telemetry", "mlflow", "alerts", "nightly", "dask", "schedule", "notifications",
          CLASS, f"{CLASS}.settings", f"{CLASS}.settings.network", f"{CLASS}.grid")


@pytest.mark.parametrize("table", TABLES)
def test_every_key_the_parser_accepts_is_documented_and_no_other(table, tmp_path):
    rows = _rows()
    accepted = _accepted(table.replace(CLASS, "classes.turbine"), tmp_path)
    if table == "":
        documented = {key.split(".")[0] for key in rows}
    else:
        prefix = f"{table}."
        documented = {key[len(prefix):].split(".")[0] for key in rows if key.startswith(prefix)}
    assert documented == set(accepted)


def test_the_documented_defaults_are_the_ones_the_parser_applies(tmp_path):
    explicit = {"classes": {"turbine": {"model": MODEL, "assets": ["T-*"]}}}
    for key, cell in _rows().items():
        value = _value(cell)
        if value is not None:
            _nest(explicit, key, value)
    assert _parse(explicit, tmp_path) == _parse(MINIMAL, tmp_path)


def _applied(config, key: str):
    section, *rest = key.replace(CLASS, "classes.turbine").split(".")
    if section == "classes":
        target = config.classes["turbine"]
        rest = rest[1:]
        if rest[0] == "settings" and len(rest) > 1:
            target, rest = target.settings, rest[1:]
            if rest[0] == "network" and len(rest) > 1:
                target, rest = target.network, rest[1:]
        elif rest[0] == "grid" and len(rest) > 1:
            target, rest = target.grid, rest[1:]
    else:
        target = getattr(config, section)
    return getattr(target, rest[0])


def test_a_key_documented_none_is_none_or_empty_when_left_out(tmp_path):
    config = _parse(MINIMAL, tmp_path)
    nones = [key for key, cell in _rows().items() if cell == "none"]
    assert nones
    for key in nones:
        assert _applied(config, key) in (None, ()), key


@pytest.mark.parametrize("key", [key for key, cell in _rows().items() if cell == "required"])
def test_a_key_documented_required_is_refused_when_missing(key, tmp_path):
    data = {"classes": {"turbine": {"model": MODEL, "assets": ["T-*"]}}}
    name = key.rsplit(".", 1)[1]
    del data["classes"]["turbine"][name]
    with pytest.raises(ConfigError, match=rf"classes\.turbine\.{name}: missing"):
        _parse(data, tmp_path)


def test_the_pages_example_file_loads(tmp_path):
    text = PAGE.read_text().split("## An example", 1)[1]
    example = re.search(r"```toml\n(.*?)```", text, re.S).group(1)
    config = _parse(tomllib.loads(example), tmp_path)
    assert config.nightly.task_runner == "dask" and config.classes["turbine"].estimate


def test_readme_and_design_point_to_the_reference_and_restate_no_default_table():
    for name in ("README.md", "docs/design.md"):
        text = (ROOT / name).read_text()
        assert "configuration.md" in text, name
        assert not re.search(r"^\| `(alerts|nightly|dask|schedule)\.[a-z_]+` \|", text,
                             re.MULTILINE), f"{name} restates the reference table"
        assert not re.search(r"^candidate_nights = \d", text, re.MULTILINE), name


#: pages whose prose may name a key beside its value: the reference itself, and the measured
#: records, which say which settings each run had
RECORDS = ("configuration.md", "benchmarks.md", "performance.md")


def restated_defaults(text: str) -> list[str]:
    """Where ``text`` gives a documented key's default beside it: ```key`, default 2``,
    ```key = 2` by default``, ```key = "auto"` (the default)``."""
    found = []
    for key, cell in _rows().items():
        default = re.fullmatch(r"`([^`]+)`", cell)
        if default is None:
            continue
        name = re.escape(key.rsplit(".", 1)[1])
        for match in re.finditer(rf"`(?:\[[a-z]+\] )?{name}(?: = ([^`]+))?`([^`\n]{{0,30}})",
                                 text):
            value, after = match.group(1), match.group(2)
            beside = re.search(rf"(?<![\w.]){re.escape(default.group(1))}(?!\w)", after)
            if "default" in after and (value == default.group(1) or beside):
                found.append(f"line {text[:match.start()].count(chr(10)) + 1}: {match.group(0)}")
    return found


def test_restated_defaults_are_found():
    text = ("x (`[nightly] candidate_nights`, default 2). y\n"
            "A (`candidate_nights = 2` by default) is\n"
            "`min_samples = \"auto\"` (the default) is\n"
            "(`[nightly] candidate_nights` > 1; the default is in configuration.md)\n")
    assert [line.split(":")[0] for line in restated_defaults(text)] == \
        ["line 1", "line 2", "line 3"]


def test_no_page_but_the_reference_restates_a_default():
    pages = [ROOT / "README.md"] + sorted(p for p in (ROOT / "docs").glob("*.md")
                                          if p.name not in RECORDS)
    found = {page.name: hits for page in pages
             if (hits := restated_defaults(page.read_text(encoding="utf-8")))}
    assert found == {}
