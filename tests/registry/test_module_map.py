"""The registry's module maps (the docstrings of ``registry/__init__.py`` and of each of its
sub-packages) name every module there is, so a reader who starts at the facade finds each."""
from __future__ import annotations

import pathlib
import re

import registry

ROOT = pathlib.Path(registry.__file__).parent


def _named(package: pathlib.Path) -> str:
    """The docstring of a package's ``__init__.py``, where its map is."""
    source = (package / "__init__.py").read_text(encoding="utf-8")
    return re.match(r'\s*"""(.*?)"""', source, re.S).group(1)


def _modules(package: pathlib.Path) -> list[str]:
    return sorted(p.stem for p in package.glob("*.py") if p.stem != "__init__")


def _packages() -> list[pathlib.Path]:
    return sorted(p.parent for p in ROOT.glob("*/__init__.py"))


def test_the_registry_map_names_every_module_and_package():
    words = set(re.findall(r"\w+", _named(ROOT)))
    missing = [m for m in _modules(ROOT) if m != "registry" and m not in words]
    missing += [f"{p.name}/" for p in _packages() if f"``{p.name}/``" not in _named(ROOT)]
    missing += [f"{p.name}/{m}" for p in _packages() for m in _modules(p) if m not in words]
    assert missing == []


def test_each_sub_package_map_names_each_of_its_modules():
    assert [p.name for p in _packages()] == ["read", "store", "write"]
    missing = [f"{p.name}/{m}" for p in _packages() for m in _modules(p)
               if f"``{m}``" not in _named(p)]
    assert missing == []
