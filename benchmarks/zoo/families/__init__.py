"""The zoo's plant families: every module of this package that defines ``FAMILY``."""
from __future__ import annotations

import argparse
import importlib
import pkgutil

from benchmarks.zoo.family import Family


def discover() -> dict[str, Family]:
    """Every family of the package, by name, in name order."""
    found = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        module = importlib.import_module(f"{__name__}.{info.name}")
        family = getattr(module, "FAMILY", None)
        if isinstance(family, Family):
            found[family.name] = family
    return found


def family_option(parser: argparse.ArgumentParser) -> dict[str, Family]:
    """Add a required ``--family`` (one of :func:`discover`'s) to a zoo tool's ``parser``.

    Returns
    -------
    dict of str -> Family
        Every family, by name (what ``--family`` chooses from).
    """
    families = discover()
    parser.add_argument("--family", required=True, choices=sorted(families))
    return families
