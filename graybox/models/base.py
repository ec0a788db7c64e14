"""The physics-model plugin contract (docs/design.md section 3.1).

A vehicle class names its white-box model as ``package.module:ClassName``. A model declares
its state, output and input variables and its default parameters as class attributes, and
computes the derivatives ``dx/dt = f(x, u)`` and the outputs ``y = g(x, u)`` over a whole
window at once. States that are not outputs are hidden: the residual estimates them from the
data (:mod:`graybox.hidden_states`).
"""
from __future__ import annotations

import functools
import importlib
import math
import re
from typing import ClassVar, Mapping, Sequence

import numpy as np

from graybox.exceptions import ModelSpecError, TelemetryError
from graybox.models.table import Table, as_table

_SPEC = re.compile(r"^[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*:[A-Za-z_]\w*$")
_NAME = re.compile(r"^[A-Za-z_]\w*$")
#: how a residual integrates the model over a sample (:mod:`graybox.integration`)
INTEGRATORS = ("auto", "rk4", "rosenbrock")


class WhiteBoxModel:
    """Base class of physics models used as the residual filter (the white box).

    Subclasses declare these class attributes and implement :meth:`derivatives`:

    ``states``
        Names of the state variables (tuple of identifiers).
    ``inputs``
        Names of the known inputs, observed in telemetry (tuple of identifiers, may be empty).
    ``default_parameters``
        Mapping of parameter name to a float or a :class:`~graybox.models.table.Table` (a
        curve, e.g. open-circuit voltage over state of charge).
    ``outputs`` (optional)
        Names of the telemetry channels the model predicts. An output named like a state is
        that state, measured; the others are computed by :meth:`output`, which a model
        declaring them implements (it may use the inputs: direct feed-through). States that
        are not outputs are *hidden*: estimated from the data, never read from telemetry.
        Left out, the outputs are the states (every state measured, the identity map).
    ``integrator`` (optional)
        ``"auto"`` (default: fixed-step RK4 where it is accurate, an L-stable Rosenbrock
        method where the model is stiff at the telemetry's rate), ``"rk4"`` or
        ``"rosenbrock"`` (:mod:`graybox.integration`).
    ``initial_state`` (optional)
        Typical values of hidden states, where the search for a window's initial hidden
        state starts (default 0).
    ``controlled_inputs`` (optional)
        Inputs that a controller sets from the plant's own state (a thermostat's heater
        power, a level loop's pump command, a speed loop's current). A fault the loop
        compensates moves them, so they do not count when the level tier asks whether a night
        lies outside the baseline's operating range (:func:`graybox.level_tier.extrapolation`);
        they still take part in its regression. Default none: every input is exogenous.
    ``positive`` (optional)
        Number parameters that are positive by nature (a time constant, a mass, an inertia,
        a resistance, a capacity, a conductance, the gain of a physical law): the diagnosis
        fits a change of one in log space, so that its estimate and interval stay positive
        (:mod:`graybox.diagnosis`). Default None: every number parameter whose
        ``default_parameters`` value is > 0. A model with positive parameters that may cross
        zero (an offset, a temperature in degrees Celsius, a linear model's coefficient)
        lists the truly positive ones instead (``positive = ("mass", "lag")``; ``()`` for
        none), as :class:`~graybox.models.linear.LinearStateSpace` does.

    A subclass meant only as a base for others is declared with ``abstract=True``
    (``class LinearStateSpace(WhiteBoxModel, abstract=True)``) and is not checked.

    Parameters
    ----------
    parameters : mapping of str to float, optional
        Overrides of ``default_parameters``. Unknown names are an error.
    columns : mapping of str to str, optional
        Model variable name -> telemetry column, where they differ.
    """

    states: ClassVar[tuple[str, ...]] = ()
    inputs: ClassVar[tuple[str, ...]] = ()
    outputs: ClassVar[tuple[str, ...]] = ()
    default_parameters: ClassVar[Mapping[str, float | Table]] = {}
    integrator: ClassVar[str] = "auto"
    initial_state: ClassVar[Mapping[str, float]] = {}
    controlled_inputs: ClassVar[tuple[str, ...]] = ()
    positive: ClassVar[tuple[str, ...] | None] = None
    _abstract: ClassVar[bool] = True
    _identity_outputs: ClassVar[bool] = True

    def __init_subclass__(cls, abstract: bool = False, **kwargs):
        super().__init_subclass__(**kwargs)
        cls._abstract = abstract
        if cls.__dict__.get("outputs"):
            cls._identity_outputs = False
        if cls._identity_outputs:
            cls.outputs = cls.states
        if not abstract:
            _check_declarations(cls)
        for method, counted in (("derivatives", "states"), ("output", "outputs")):
            if method in cls.__dict__:
                setattr(cls, method, _shape_checked(cls.__dict__[method], counted))

    def __init__(self, parameters: Mapping[str, float] | None = None,
                 columns: Mapping[str, str] | None = None):
        if type(self)._abstract:
            raise ModelSpecError(f"{type(self).__name__} is an abstract model base; subclass it")
        merged = dict(self.default_parameters)
        for name, value in (parameters or {}).items():
            if name not in merged:
                raise ModelSpecError(
                    f"{self.spec()}: unknown parameter {name!r}; "
                    f"known parameters: {', '.join(sorted(merged)) or '(none)'}")
            what = f"{self.spec()}: parameter {name!r}"
            merged[name] = (as_table(value, what) if isinstance(merged[name], Table)
                            else _as_finite_float(value, what))
        self.parameters: dict[str, float | Table] = merged
        variables = self.outputs + self.inputs
        mapping = {name: name for name in variables}
        for name, column in (columns or {}).items():
            if name not in mapping:
                raise ModelSpecError(
                    f"{self.spec()}: column map names {name!r}, which is not a model variable; "
                    f"variables: {', '.join(variables)}")
            if not isinstance(column, str) or not column:
                raise ModelSpecError(f"{self.spec()}: column for {name!r} must be a non-empty string")
            mapping[name] = column
        if len(set(mapping.values())) != len(mapping):
            raise ModelSpecError(f"{self.spec()}: two model variables map to the same column: {mapping}")
        self.columns: dict[str, str] = mapping
        self.check_parameters()

    # -- what subclasses provide -------------------------------------------------------------
    def derivatives(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Return ``dx/dt = f(x, u)``.

        Parameters
        ----------
        x : ndarray of shape (T, len(states))
        u : ndarray of shape (T, len(inputs))

        Returns
        -------
        ndarray of shape (T, len(states))

        Notes
        -----
        Written with ``x[..., i]`` and elementwise operations, the same code also serves a
        :meth:`stacked` model (the simulator's fleet of plants).
        """
        raise NotImplementedError

    def output(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Return the predicted outputs ``y = g(x, u)``.

        The default returns the measured states (outputs named like states), which is all a
        model without other outputs needs.

        Parameters
        ----------
        x : ndarray of shape (T, len(states))
        u : ndarray of shape (T, len(inputs))

        Returns
        -------
        ndarray of shape (T, len(outputs))
        """
        return x[..., [self.states.index(name) for name in self.outputs]]

    def check_parameters(self) -> None:
        """Raise :class:`ModelSpecError` if the parameters are physically invalid (hook)."""

    @classmethod
    def stacked(cls, models: Sequence["WhiteBoxModel"]) -> "WhiteBoxModel":
        """One model of this class whose parameters are arrays over ``models`` (last axis).

        For simulating many vehicles at once with the model's own :meth:`derivatives`: a
        model written with elementwise operations on ``x[..., i]`` and its parameters
        evaluates every vehicle in one call (``x`` of shape ``(..., n_vehicles, n_states)``).
        Each model was checked when it was built; the stack is not checked again.
        """
        if not models or any(type(m) is not cls for m in models):
            raise ModelSpecError(f"{cls.__name__}.stacked needs one or more {cls.__name__} models")
        stack = cls.__new__(cls)
        stack.parameters = {}
        for name, value in models[0].parameters.items():
            if isinstance(value, Table):
                if any(m.parameters[name] != value for m in models):
                    raise ModelSpecError(f"{cls.__name__}.stacked: the models' tables "
                                         f"{name!r} differ; a stack shares its tables")
                stack.parameters[name] = value
            else:
                stack.parameters[name] = np.array([m.parameters[name] for m in models])
        stack.columns = dict(models[0].columns)
        return stack

    def subset(self, which) -> "WhiteBoxModel":
        """The models selected by ``which`` (index or mask) of a :meth:`stacked` model."""
        sub = type(self).__new__(type(self))
        sub.parameters = {name: value if isinstance(value, Table) else value[which]
                          for name, value in self.parameters.items()}
        sub.columns = dict(self.columns)
        return sub

    # -- shared behaviour ----------------------------------------------------------------------
    @classmethod
    def spec(cls) -> str:
        """The ``package.module:ClassName`` string that loads this model."""
        return f"{cls.__module__}:{cls.__qualname__}"

    @classmethod
    def fingerprint(cls) -> str | None:
        """What identifies the model's equations beyond its spec, when a file outside the
        code holds them (an FMU's GUID); recorded with every fit, and a record whose
        fingerprint differs is refused. None (the default): the spec is the identity."""
        return None

    @property
    def hidden_states(self) -> tuple[str, ...]:
        """States that are not outputs: estimated from the data, never read."""
        return tuple(name for name in self.states if name not in self.outputs)

    @property
    def state_columns(self) -> tuple[str, ...]:
        """Telemetry columns of the measured states (states that are outputs), in state order."""
        return tuple(self.columns[name] for name in self.states if name in self.outputs)

    @property
    def output_columns(self) -> tuple[str, ...]:
        """Telemetry columns of the outputs (the channels), in declaration order."""
        return tuple(self.columns[name] for name in self.outputs)

    @property
    def input_columns(self) -> tuple[str, ...]:
        """Telemetry columns of the inputs, in declaration order."""
        return tuple(self.columns[name] for name in self.inputs)

    @property
    def required_columns(self) -> tuple[str, ...]:
        """Every telemetry column the model reads: outputs, then inputs."""
        return self.output_columns + self.input_columns

    def check_columns(self, available, asset_id: str = "?", file: str | None = None) -> None:
        """Raise :class:`TelemetryError` naming every required column missing from ``available``."""
        available = set(available)
        missing = [f"{self.columns[v]!r} (model variable {v!r})"
                   for v in self.outputs + self.inputs if self.columns[v] not in available]
        if missing:
            raise TelemetryError(
                asset_id, "schema",
                f"{type(self).__name__} needs column(s) {', '.join(missing)}; "
                f"telemetry has: {', '.join(sorted(available)) or '(none)'}", file=file)

    def to_dict(self) -> dict:
        """Spec, parameters and column map: enough to rebuild the model with :func:`load_model`."""
        parameters = {name: value.to_dict() if isinstance(value, Table) else value
                      for name, value in self.parameters.items()}
        return {"spec": self.spec(), "parameters": parameters, "columns": dict(self.columns)}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(parameters={self.parameters!r})"


def _shape_checked(method, counted: str):
    """``method`` (``derivatives`` or ``output``) returning one column per name of
    ``counted`` (``"states"`` or ``"outputs"``) for every row of ``x``, or an error that says
    so. A model of one state or output may return the rows alone (``(T,)`` for ``(T, 1)``:
    ``(u[..., 0] - x[..., 0]) / tau`` is how such a model is naturally written)."""

    @functools.wraps(method)
    def shaped(self, x, u):
        result = method(self, x, u)
        columns = len(getattr(self, counted))
        expected = np.shape(x)[:-1] + (columns,)
        if getattr(result, "shape", None) == expected:
            return result
        result = np.asarray(result, dtype=float)
        if columns == 1 and result.shape == expected[:-1]:
            return result[..., None]
        raise ModelSpecError(
            f"{type(self).__name__}.{method.__name__}(x, u) returned an array of shape "
            f"{result.shape} for x of shape {np.shape(x)}; it must return {expected}: one "
            f"column per name of {counted} {getattr(self, counted)}, in that order, for every "
            f"row (build it with np.stack([...], axis=-1) from x[..., i] and u[..., j])")

    return shaped


def _as_finite_float(value, what: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ModelSpecError(f"{what} must be a number, got {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(number):
        raise ModelSpecError(f"{what} must be a finite number, got {value!r}")
    return number


def _check_declarations(cls) -> None:
    name = cls.__qualname__
    for attribute in ("states", "inputs", "outputs", "controlled_inputs"):
        value = getattr(cls, attribute)
        if not isinstance(value, tuple) or not all(isinstance(v, str) and _NAME.match(v) for v in value):
            raise ModelSpecError(f"{name}.{attribute} must be a tuple of identifiers, got {value!r}")
        if len(set(value)) != len(value):
            raise ModelSpecError(f"{name}.{attribute} repeats a name: {value!r}")
    if not cls.states:
        raise ModelSpecError(f"{name}.states must name at least one state variable")
    overlap = set(cls.states) & set(cls.inputs)
    if overlap:
        raise ModelSpecError(f"{name}: {sorted(overlap)} declared both as state and input")
    overlap = set(cls.outputs) & set(cls.inputs)
    if overlap:
        raise ModelSpecError(f"{name}: {sorted(overlap)} declared both as output and input")
    unknown = set(cls.controlled_inputs) - set(cls.inputs)
    if unknown:
        raise ModelSpecError(f"{name}.controlled_inputs names {sorted(unknown)}, which are not "
                             f"inputs; inputs: {', '.join(cls.inputs) or '(none)'}")
    computed = [o for o in cls.outputs if o not in cls.states]
    if computed and cls.output is WhiteBoxModel.output:
        raise ModelSpecError(f"{name}: outputs {computed} are not states; implement "
                             f"output(x, u) to compute them")
    if cls.integrator not in INTEGRATORS:
        raise ModelSpecError(f"{name}.integrator must be one of {INTEGRATORS}, got "
                             f"{cls.integrator!r}")
    if not isinstance(cls.default_parameters, Mapping):
        raise ModelSpecError(f"{name}.default_parameters must be a mapping of name to float")
    for key, value in cls.default_parameters.items():
        if not isinstance(key, str):
            raise ModelSpecError(f"{name}.default_parameters has a non-string key {key!r}")
        if not isinstance(value, Table):
            _as_finite_float(value, f"{name}.default_parameters[{key!r}]")
    if cls.derivatives is WhiteBoxModel.derivatives:
        raise ModelSpecError(f"{name} must implement derivatives(x, u)")


def import_spec(spec: str, what: str = "model spec") -> object:
    """The object named ``package.module:Name`` (the module is imported).

    Raises
    ------
    ModelSpecError
        If the spec is malformed, the module cannot be imported, or it has no such name;
        the message starts with ``what`` and the spec.
    """
    if not isinstance(spec, str) or not _SPEC.match(spec):
        raise ModelSpecError(f"{what} {spec!r} is not of the form 'package.module:ClassName'")
    module_name, class_name = spec.split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        hint = ""
        if isinstance(error, ModuleNotFoundError) and error.name == module_name.split(".")[0]:
            hint = (f" (the folder that holds {error.name!r} must be importable where the "
                    f"flows run: e.g. PYTHONPATH=. when it sits beside fleet.toml)")
        raise ModelSpecError(f"{what} {spec!r}: cannot import {module_name!r}: {error}{hint}"
                             ) from None
    found = getattr(module, class_name, None)
    if found is None:
        raise ModelSpecError(f"{what} {spec!r}: module {module_name!r} has no {class_name!r}")
    return found


def model_class(spec: str) -> type[WhiteBoxModel]:
    """The concrete white-box class ``spec`` names: ``package.module:ClassName`` (the module
    is imported) or ``fmu:<path>``, an FMU file (its class is made,
    :mod:`graybox.models.fmu_file`).

    Raises
    ------
    ModelSpecError
        As :func:`load_model`.
    """
    from graybox.models import fmu_file   # FMPy is imported only for an FMU's spec

    if fmu_file.is_fmu_spec(spec):
        return fmu_file.file_model_class(spec)
    cls = import_spec(spec)
    class_name = spec.split(":")[1]
    if not (isinstance(cls, type) and issubclass(cls, WhiteBoxModel)):
        raise ModelSpecError(f"model spec {spec!r}: {class_name} is not a WhiteBoxModel subclass")
    if cls._abstract:
        raise ModelSpecError(f"model spec {spec!r}: {class_name} is an abstract model base")
    return cls


def load_model(spec: str, parameters: Mapping[str, float] | None = None,
               columns: Mapping[str, str] | None = None) -> WhiteBoxModel:
    """Import and instantiate a physics model named ``package.module:ClassName``, or the FMU
    file named ``fmu:<path>`` (absolute, ``~/...``, or relative to the working directory).

    Parameters
    ----------
    spec : str
        For example ``"graybox.models:GasTurbineShaft"`` or ``"fmu:/plants/pump.fmu"``.
    parameters : mapping, optional
        Overrides of the model's ``default_parameters``.
    columns : mapping, optional
        Model variable name -> telemetry column.

    Returns
    -------
    WhiteBoxModel

    Raises
    ------
    ModelSpecError
        If the spec is malformed, the module or class does not exist, the class is not a
        concrete :class:`WhiteBoxModel`, an FMU file is missing or unusable (or FMPy is not
        installed), or a parameter or column is unknown or invalid.
    """
    return model_class(spec)(parameters=parameters, columns=columns)
