"""The white box a signature was fitted with, as a frozen record: spec, parameters, columns.

A stored record names a Python class, and importing its module runs that module's code (or
an FMU file, and loading its binary runs the binary's), so :meth:`ModelSpec.load` never
imports a module or loads a file a record chose: given ``allowed`` (the specs the caller
trusts, e.g. the vehicle class's ``model`` from fleet.toml) the record's spec must be one of
them before anything is imported; without it, the spec's module must already be imported (a
record made in this process, or a built-in model), or the FMU file's class already made in
this process (:func:`graybox.models.fmu_file.made`).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import ClassVar, Collection, Mapping

from graybox import record_json
from graybox.exceptions import ModelChangedError, ModelSpecError
from graybox.frozen_map import FrozenMap
from graybox.models import fmu_file
from graybox.models.base import WhiteBoxModel, model_class
from graybox.models.table import Table


@dataclass(frozen=True)
class ModelSpec:
    """Enough to rebuild a white box with :func:`~graybox.models.base.load_model`.

    Attributes
    ----------
    spec : str
        ``package.module:ClassName``, e.g. ``"graybox.models.gas_turbine:LangevinShaft"``, or
        ``fmu:`` and the absolute path of an FMU file (:mod:`graybox.models.fmu_file`).
    parameters : FrozenMap of str to float or Table
        The model's parameters (all of them when made by :meth:`from_model`).
    columns : FrozenMap of str to str
        Model variable -> telemetry column.
    fingerprint : str or None
        The model's :meth:`~graybox.models.base.WhiteBoxModel.fingerprint` when fitted (an
        FMU's GUID); written only when present. :meth:`load` refuses a model whose
        fingerprint is now another.

    Mappings given as dicts are copied into :class:`~graybox.frozen_map.FrozenMap`, so the
    record is hashable and later changes of the caller's dict do not reach it.

    Examples
    --------
    >>> spec = ModelSpec("graybox.models.gas_turbine:LangevinShaft", {"gamma": 0.06})
    >>> ModelSpec.from_model(spec.load()).parameters["gamma"]
    0.06
    """

    spec: str
    parameters: FrozenMap[str, float | Table] = FrozenMap()
    columns: FrozenMap[str, str] = FrozenMap()
    fingerprint: str | None = None

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"fingerprint"})

    def __post_init__(self):
        for name in ("parameters", "columns"):
            value = getattr(self, name)
            if not isinstance(value, FrozenMap):
                object.__setattr__(self, name, FrozenMap(value))

    @classmethod
    def from_model(cls, model: WhiteBoxModel) -> "ModelSpec":
        """The record of a white box instance."""
        return cls(model.spec(), model.parameters, model.columns, model.fingerprint())

    def load(self, allowed: Collection[str] | None = None) -> WhiteBoxModel:
        """The white box, built without importing a module the record alone chose.

        Parameters
        ----------
        allowed : collection of str, optional
            The ``package.module:ClassName`` specs the caller trusts; the record's spec must
            be one of them (checked before anything is imported). None: the spec's module
            must already be imported.

        Raises
        ------
        graybox.exceptions.ModelSpecError
            If the spec is not allowed (or, without ``allowed``, not imported or made yet),
            or the white box cannot be built.
        graybox.exceptions.ModelChangedError
            If the record has a fingerprint and the model's is now another (an FMU replaced
            since the fit): its parameters and calibration belong to the other model.
        """
        if allowed is not None:
            if self.spec not in allowed:
                raise ModelSpecError(f"model spec {self.spec!r} is not an allowed model "
                                     f"({', '.join(sorted(allowed)) or 'none'}); it was not "
                                     f"imported")
        elif fmu_file.is_fmu_spec(self.spec):
            if not fmu_file.made(self.spec):
                raise ModelSpecError(f"model spec {self.spec!r}: this process has not loaded "
                                     f"that FMU and a stored record may not choose which "
                                     f"binary is loaded; load it first or name the spec in "
                                     f"allowed")
        elif self.spec.partition(":")[0] not in sys.modules:
            raise ModelSpecError(f"model spec {self.spec!r}: its module is not imported and a "
                                 f"stored record may not choose what is imported; import it "
                                 f"first or name the spec in allowed")
        cls = model_class(self.spec)
        now = cls.fingerprint()   # before its parameters meet the model as it is now
        if self.fingerprint is not None and now != self.fingerprint:
            raise ModelChangedError(f"model {self.spec!r} was fitted as {self.fingerprint!r} "
                                    f"and is now {now!r} (its file was replaced or "
                                    f"re-exported): fit a new baseline with the model as it is")
        return cls(parameters=self.parameters, columns=self.columns)

    def to_dict(self) -> dict:
        """``{"spec", "parameters", "columns"}``, as :meth:`WhiteBoxModel.to_dict` writes."""
        return record_json.to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping) -> "ModelSpec":
        """Inverse of :meth:`to_dict` (raises ArtifactError on malformed input)."""
        return record_json.from_dict(cls, data)
