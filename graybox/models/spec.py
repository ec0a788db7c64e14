"""The white box a signature was fitted with, as a frozen record: spec, parameters, columns."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from graybox import records
from graybox.frozen_map import FrozenMap
from graybox.models.base import WhiteBoxModel, load_model


@dataclass(frozen=True)
class ModelSpec:
    """Enough to rebuild a white box with :func:`~graybox.models.base.load_model`.

    Attributes
    ----------
    spec : str
        ``package.module:ClassName``, e.g. ``"graybox.models.gas_turbine:LangevinShaft"``.
    parameters : FrozenMap of str to float
        The model's parameters (all of them when made by :meth:`from_model`).
    columns : FrozenMap of str to str
        Model variable -> telemetry column.

    Mappings given as dicts are copied into :class:`~graybox.frozen_map.FrozenMap`, so the
    record is hashable and later changes of the caller's dict do not reach it.

    Examples
    --------
    >>> spec = ModelSpec("graybox.models.gas_turbine:LangevinShaft", {"gamma": 0.06})
    >>> ModelSpec.from_model(spec.load()).parameters["gamma"]
    0.06
    """

    spec: str
    parameters: FrozenMap[str, float] = FrozenMap()
    columns: FrozenMap[str, str] = FrozenMap()

    def __post_init__(self):
        for name in ("parameters", "columns"):
            value = getattr(self, name)
            if not isinstance(value, FrozenMap):
                object.__setattr__(self, name, FrozenMap(value))

    @classmethod
    def from_model(cls, model: WhiteBoxModel) -> "ModelSpec":
        """The record of a white box instance."""
        return cls(model.spec(), model.parameters, model.columns)

    def load(self) -> WhiteBoxModel:
        """The white box (raises :class:`~graybox.exceptions.ModelSpecError` if it cannot)."""
        return load_model(self.spec, self.parameters, self.columns)

    def to_dict(self) -> dict:
        """``{"spec", "parameters", "columns"}``, as :meth:`WhiteBoxModel.to_dict` writes."""
        return records.to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping) -> "ModelSpec":
        """Inverse of :meth:`to_dict` (raises ArtifactError on malformed input)."""
        return records.from_dict(cls, data)
