"""The graybox tests' FMU (tests/graybox/models/plant_fmu.py: plant.c built with ``cc``, its
Python twin and its simulation) for the flow tests, loaded by its path."""
from __future__ import annotations

import importlib.util
import pathlib
import sys


def plant_fmu():
    """The module tests/graybox/models/plant_fmu.py."""
    if "plant_fmu" not in sys.modules:
        path = pathlib.Path(__file__).parents[1] / "graybox" / "models" / "plant_fmu.py"
        spec = importlib.util.spec_from_file_location("plant_fmu", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules["plant_fmu"] = module
        spec.loader.exec_module(module)
    return sys.modules["plant_fmu"]
