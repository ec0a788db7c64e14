"""The flows reach the registry only through its facade: :class:`registry.Registry`'s methods
and the registry package's public names (``registry.__all__``), never its backend, MLflow's
client behind it, or a module inside the registry."""
from __future__ import annotations

import ast
import pathlib
import re

import flows
import registry

FLOWS = pathlib.Path(flows.__file__).parent
BACKEND = re.compile(r"\.(_?backend)\b")


def reaches_past_the_facade(source: str) -> list[str]:
    """The lines of a module's source that use the registry beyond its facade: a
    ``.backend``, an import of a module inside the registry, or of a name it does not
    publish."""
    lines = source.splitlines()
    found = {n for n, line in enumerate(lines, 1) if BACKEND.search(line)}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            if any(alias.name.split(".")[0] == "registry" for alias in node.names):
                found.add(node.lineno)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module \
                and node.module.split(".")[0] == "registry":
            names = {alias.name for alias in node.names}
            if node.module != "registry" or names - set(registry.__all__):
                found.add(node.lineno)
    return [f"line {n}: {lines[n - 1].strip()}" for n in sorted(found)]


def test_the_scan_finds_each_way_past_the_facade():
    source = ("from registry import Registry, RegistryError\n"
              "from registry.store.backend import Backend\n"
              "from registry import naming\n"
              "import registry.read.history\n"
              "def f(config):\n"
              "    return config.registry().backend.client.search_runs([])\n")
    assert [line.split(":")[0] for line in reaches_past_the_facade(source)] == \
        ["line 2", "line 3", "line 4", "line 6"]


def test_flows_use_only_the_registry_facade():
    sources = sorted(FLOWS.rglob("*.py"))
    assert FLOWS / "commands" / "check.py" in sources
    offenders = {str(path.relative_to(FLOWS.parent)): found for path in sources
                 if (found := reaches_past_the_facade(path.read_text(encoding="utf-8")))}
    assert offenders == {}


def test_every_public_name_of_the_registry_package_resolves():
    for name in registry.__all__:
        assert getattr(registry, name).__name__ == name
