"""Type checks of a parsed ``fleet.toml`` whose errors name the file and the dotted key."""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping

from flows.errors import ConfigError


class Checker:
    """Type checks whose errors name the file and the dotted key."""

    def __init__(self, file_name: str):
        self.file_name = file_name

    def error(self, key: str, message: str) -> ConfigError:
        return ConfigError(f"{self.file_name}: {key}: {message}" if key
                           else f"{self.file_name}: {message}")

    def keys(self, key: str, table: Mapping, known) -> None:
        for name in table:
            if name not in known:
                where = f"{key}.{name}" if key else name
                raise self.error(where, f"unknown key; expected one of {', '.join(known)}")

    def fields(self, key: str, table: Mapping, record) -> None:
        """Refuse a name that is not a field of the dataclass ``record``."""
        known = sorted(f.name for f in dataclasses.fields(record))
        for name in table:
            if name not in known:
                raise self.error(f"{key}.{name}", f"unknown setting; known: {', '.join(known)}")

    def build(self, key: str, make, values: Mapping):
        """``make(**values)``, its TypeError or ValueError reported at ``key``."""
        try:
            return make(**values)
        except (TypeError, ValueError) as error:
            raise self.error(key, str(error)) from None

    def table(self, key: str, value, required: bool = False) -> dict:
        if value is None:
            if required:
                raise self.error(key, "missing table")
            return {}
        if not isinstance(value, dict):
            raise self.error(key, f"must be a table, got {type(value).__name__} {value!r}")
        return value

    def string(self, key: str, value) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(key, f"must be a non-empty string, got {value!r}")
        return value

    def number(self, key: str, value) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {value!r}")
        return float(value)

    def integer(self, key: str, value, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.error(key, f"must be an integer >= {low}, got {value!r}")
        return int(value)
