"""ProgPy prognostics models (NASA's ``progpy``) as white boxes.

Any :class:`progpy.PrognosticsModel` becomes a :class:`~graybox.models.base.WhiteBoxModel`:

- a model of ProgPy's catalogue by name, ``graybox.models.progpy:<Name>`` for every
  ``progpy.models.<Name>`` (``CentrifugalPump``, ``BatteryCircuit``, ``PneumaticValve``,
  ``ThrownObject``, ...);
- any other ProgPy model by a two-line subclass of :class:`ProgPyModel` naming it::

      class MyPump(ProgPyModel):
          progpy_model = "mypackage.models:MyPump"

**Variables.** The white box's inputs are the ProgPy model's inputs. Its states are the
ProgPy states observed in telemetry: every state that is also a ProgPy output of the same
name, plus every state named in the column map (``columns = {Q = "Qout"}`` observes the
pump's flow ``Q`` in the column ``Qout``). A state not observed is held at its parameter
``x0_<state>`` (default: the ProgPy model's ``parameters["x0"]``, 0 where it has none),
which suits the slow wear and damage states (a pump's impeller area ``A``, friction
coefficients, wear rates) and makes a drift of them show in the residual as the fault.

**Parameters.** Every scalar numeric ProgPy parameter (``I``, ``r``, ``c``, ... for the
pump) is a white-box parameter of the same name, overridable in ``fleet.toml``; noise
parameters, nested tables and parameters that a state of the same name overrides are not.
Two more kinds: ``x0_<state>`` (above) and, for a discrete model, ``derivative_step``.

**Dynamics.** A continuous model (one defining ``dx``) gives the derivatives directly. A
discrete model (one defining only ``next_state``) is differentiated as
``(next_state(x, u, h) - x) / h`` with ``h = derivative_step`` seconds: exact for the
Euler-form transitions of ProgPy's catalogue (``x + xdot * dt``, e.g. ``CentrifugalPump``),
a first-order approximation otherwise. The residual then integrates these derivatives with
RK4 exactly as for the built-in models. No noise is applied: the process and measurement
noise are what the residual is made of.

ProgPy is imported here only, on first use; without it, loading a ProgPy model is a
:class:`~graybox.exceptions.ModelSpecError` saying how to install it.
"""
from __future__ import annotations

import functools
import importlib
import numbers
import warnings
from typing import Any, ClassVar, Mapping

import numpy as np

from graybox.exceptions import ModelSpecError
from graybox.models.base import WhiteBoxModel, import_spec

#: white-box parameter prefix of the value an unobserved state is held at
HOLD_PREFIX = "x0_"
#: seconds of the step that differentiates a discrete model's ``next_state``
DEFAULT_DERIVATIVE_STEP = 1e-3
_NOT_PARAMETERS = frozenset({"process_noise", "measurement_noise", "process_noise_dist",
                             "measurement_noise_dist", "x0"})
_INSTALL = "install it with: pip install 'fleet-health[progpy]'"


def _import_progpy():
    try:
        return importlib.import_module("progpy")
    except ImportError as error:
        raise ModelSpecError(f"ProgPy models need the progpy package ({error}); {_INSTALL}") from None


def resolve_progpy_class(spec: str) -> type:
    """The ProgPy model class named ``package.module:ClassName``.

    Raises
    ------
    ModelSpecError
        If progpy is missing, the spec is malformed, or it names no ``PrognosticsModel``.
    """
    progpy = _import_progpy()
    cls = import_spec(spec, what="ProgPy model")
    if not (isinstance(cls, type) and issubclass(cls, progpy.PrognosticsModel)):
        raise ModelSpecError(f"ProgPy model {spec!r} is not a progpy.PrognosticsModel subclass")
    return cls


def _identifiers(names, what: str, spec: str) -> tuple[str, ...]:
    names = tuple(str(name) for name in names)
    bad = [name for name in names if not name.isidentifier()]
    if bad:
        raise ModelSpecError(f"ProgPy model {spec}: {what} {bad} are not identifiers")
    return names


def _scalar_parameters(parameters: Mapping[str, Any], states: tuple[str, ...]) -> dict[str, float]:
    """ProgPy's scalar numeric parameters, less noise and those a state overrides."""
    scalars = {}
    for name, value in parameters.items():
        if name in _NOT_PARAMETERS or name in states or not str(name).isidentifier():
            continue
        if isinstance(value, numbers.Real) and not isinstance(value, bool) and np.isfinite(value):
            scalars[str(name)] = float(value)
    return scalars


def _derived_parameters(progpy_class: type, default) -> set[str]:
    """Parameters ProgPy computes from others (its ``param_callbacks``): not overridable."""
    derived = set()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for callbacks in getattr(progpy_class, "param_callbacks", {}).values():
            for callback in callbacks:
                try:
                    derived.update(callback(default.parameters) or {})
                except Exception:  # a callback that cannot run on the defaults derives nothing we can name
                    continue
    return derived


def _hold_defaults(parameters: Mapping[str, Any], states: tuple[str, ...]) -> dict[str, float]:
    x0 = parameters.get("x0") if "x0" in parameters else None
    x0 = x0 if isinstance(x0, Mapping) else {}
    defaults = {}
    for state in states:
        value = x0.get(state, 0.0)
        number = float(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) else 0.0
        defaults[HOLD_PREFIX + state] = number if np.isfinite(number) else 0.0
    return defaults


class ProgPyModel(WhiteBoxModel, abstract=True):
    """Base of white boxes that wrap a ProgPy ``PrognosticsModel``.

    A subclass sets ``progpy_model`` (``"package.module:ClassName"`` of the ProgPy model);
    its ``inputs`` and ``default_parameters`` are then taken from that model when the class
    is created. See the module docstring for the variables, parameters and dynamics.

    Parameters
    ----------
    parameters : mapping of str to float, optional
        Overrides: ProgPy scalar parameters by name, ``x0_<state>`` for the value an
        unobserved state is held at, ``derivative_step`` (discrete models).
    columns : mapping of str to str, optional
        Model variable (ProgPy state or input) -> telemetry column. Naming a state that is not
        a ProgPy output observes it.

    Attributes
    ----------
    progpy : progpy.PrognosticsModel
        The wrapped model, built with the ProgPy parameter overrides.
    progpy_states : tuple of str
        All ProgPy states, observed or not.
    states : tuple of str
        The observed states (instance attribute), in ProgPy's order.
    """

    progpy_model: ClassVar[str] = ""
    progpy_states: ClassVar[tuple[str, ...]] = ()
    progpy_outputs: ClassVar[tuple[str, ...]] = ()
    progpy_parameters: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, abstract: bool = False, **kwargs):
        if not abstract:
            cls._declare_from_progpy()
        super().__init_subclass__(abstract=abstract, **kwargs)

    @classmethod
    def _declare_from_progpy(cls) -> None:
        if not cls.progpy_model:
            raise ModelSpecError(f"{cls.__qualname__}.progpy_model must name a ProgPy model "
                                 f"('package.module:ClassName')")
        progpy_class = resolve_progpy_class(cls.progpy_model)
        with warnings.catch_warnings():
            # CentrifugalPump warns on construction that its wear-rate parameters are states
            warnings.simplefilter("ignore", UserWarning)
            default = progpy_class()
        states = _identifiers(default.states, "states", cls.progpy_model)
        cls.progpy_states = states
        cls.progpy_outputs = _identifiers(default.outputs, "outputs", cls.progpy_model)
        cls.inputs = _identifiers(default.inputs, "inputs", cls.progpy_model)
        # the class-level states (checked by WhiteBoxModel) are all ProgPy states; each
        # instance narrows them to the observed ones
        cls.states = states
        parameters = _scalar_parameters(default.parameters, states)
        for name in _derived_parameters(progpy_class, default):
            parameters.pop(name, None)
        cls.progpy_parameters = tuple(parameters)
        parameters.update(_hold_defaults(default.parameters, states))
        if default.is_discrete:
            parameters["derivative_step"] = DEFAULT_DERIVATIVE_STEP
        cls.default_parameters = parameters
        cls._progpy_class = progpy_class

    def __init__(self, parameters: Mapping[str, float] | None = None,
                 columns: Mapping[str, str] | None = None):
        if type(self)._abstract:
            raise ModelSpecError(f"{type(self).__name__} is an abstract model base; subclass it")
        columns = dict(columns or {})
        unknown = [n for n in columns if n not in self.progpy_states and n not in self.inputs]
        if unknown:
            raise ModelSpecError(
                f"{self.spec()}: column map names {unknown}, which are not ProgPy states or "
                f"inputs; states: {', '.join(self.progpy_states)}; inputs: "
                f"{', '.join(self.inputs) or '(none)'}")
        observed = tuple(s for s in self.progpy_states
                         if s in self.progpy_outputs or s in columns)
        if not observed:
            raise ModelSpecError(
                f"{self.spec()}: no ProgPy state is observed: none is a ProgPy output of the "
                f"same name ({', '.join(self.progpy_outputs)}); map at least one state to its "
                f"telemetry column in 'columns' (states: {', '.join(self.progpy_states)})")
        for name in parameters or {}:
            if name in self.progpy_states and name not in self.default_parameters:
                raise ModelSpecError(
                    f"{self.spec()}: {name!r} is a ProgPy state of this model, not a parameter; "
                    f"the value it is held at when not observed is the parameter "
                    f"'{HOLD_PREFIX}{name}'")
        self.states = observed
        self.outputs = observed
        super().__init__(parameters, columns)
        overrides = {name: self.parameters[name] for name in self.progpy_parameters
                     if self.parameters[name] != self.default_parameters[name]}
        self.progpy_overrides: dict[str, float] = overrides
        self.progpy = self.make_progpy()
        self._observed_rows = np.array([self.progpy_states.index(s) for s in observed])
        self._held = np.array([self.parameters[HOLD_PREFIX + s] for s in self.progpy_states])
        self._inputs_batch: bool | None = None

    def make_progpy(self, **options):
        """A new instance of the ProgPy model with this white box's parameter overrides.

        Parameters
        ----------
        **options
            More ProgPy keyword arguments, e.g. ``process_noise`` or ``measurement_noise``.
        """
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                return self._progpy_class(**self.progpy_overrides, **options)
        except Exception as error:  # ProgPy's own parameter checks
            raise ModelSpecError(f"{self.spec()}: ProgPy rejected the parameters "
                                 f"{self.progpy_overrides} {options}: {error}") from None

    def check_parameters(self) -> None:
        step = self.parameters.get("derivative_step")
        if step is not None and not step > 0:
            raise ModelSpecError(f"{type(self).__name__}: derivative_step must be > 0, got {step}")

    @property
    def is_discrete(self) -> bool:
        """Whether the ProgPy model defines only ``next_state`` (no ``dx``)."""
        return bool(self.progpy.is_discrete)

    def full_state(self, x: np.ndarray) -> np.ndarray:
        """ProgPy state matrix (n_progpy_states, T): observed rows from ``x`` (T, n_states),
        the others held at their ``x0_<state>`` parameters."""
        x = np.asarray(x, dtype=float)
        full = np.repeat(self._held[:, None], len(x), axis=1)
        full[self._observed_rows] = x.T
        return full

    def derivatives(self, x, u):
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float).reshape(len(x), len(self.inputs))
        full = self.full_state(x)
        if self.progpy.is_vectorized:
            rates = self._vectorised_rates(full, u)
        else:
            rates = np.empty_like(full)
            for t in range(full.shape[1]):
                rates[:, t:t + 1] = self._progpy_rates(full[:, t:t + 1], u[t:t + 1].T)
        return rates[self._observed_rows].T

    def _vectorised_rates(self, full: np.ndarray, u: np.ndarray) -> np.ndarray:
        if self._inputs_batch is None:
            self._inputs_batch = self._batch_handles_varying_inputs(full, u)
        if self._inputs_batch:
            return self._progpy_rates(full, u.T)
        # One batch per distinct input: some vectorised ProgPy models fail (or, worse, build
        # a T x T matrix) when the inputs vary within a batch (CentrifugalPump's leak flow).
        distinct, which = np.unique(u, axis=0, return_inverse=True)
        which = which.reshape(-1)
        order = np.argsort(which, kind="stable")
        bounds = np.cumsum(np.bincount(which, minlength=len(distinct)))[:-1]
        rates = np.empty_like(full)
        for row, columns in zip(distinct, np.split(order, bounds)):
            rates[:, columns] = self._progpy_rates(full[:, columns], row[:, None])
        return rates

    def _batch_handles_varying_inputs(self, full: np.ndarray, u: np.ndarray) -> bool:
        """Whether a batch with varying inputs gives the per-sample rates (probed on 3
        samples with distinct inputs; ``None`` until probed)."""
        _, first = np.unique(u, axis=0, return_index=True)
        probe = np.sort(first)[:3]
        if len(probe) < 2:
            return False
        alone = np.concatenate([self._progpy_rates(full[:, [t]], u[[t]].T) for t in probe], axis=1)
        try:
            together = self._progpy_rates(full[:, probe], u[probe].T)
        except (ValueError, TypeError, IndexError):
            return False
        return together.shape == alone.shape and np.allclose(together, alone, rtol=1e-12,
                                                             atol=0.0, equal_nan=True)

    def _progpy_rates(self, full: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        model = self.progpy
        state = model.StateContainer(full.copy())
        load = model.InputContainer(inputs.copy())
        if not model.is_discrete:
            rates = model.dx(state, load)
            return np.asarray(rates.matrix, dtype=float).reshape(full.shape)
        step = self.parameters["derivative_step"]
        following = np.asarray(model.next_state(state, load, step).matrix, dtype=float)
        return (following.reshape(full.shape) - full) / step

    @classmethod
    def progpy_class(cls) -> type:
        """The wrapped ``progpy.PrognosticsModel`` subclass."""
        return cls._progpy_class


@functools.cache
def catalogue_model(name: str) -> type[ProgPyModel]:
    """The white-box class of ``progpy.models.<name>``, created once per name.

    Raises
    ------
    AttributeError
        If ``progpy.models`` has no model of that name.
    """
    _import_progpy()
    catalogue = importlib.import_module("progpy.models")
    progpy = importlib.import_module("progpy")
    candidate = getattr(catalogue, name, None)
    if not (isinstance(candidate, type) and issubclass(candidate, progpy.PrognosticsModel)):
        raise AttributeError(f"progpy.models has no model {name!r}")
    namespace = {"progpy_model": f"progpy.models:{name}", "__module__": __name__,
                 "__qualname__": name,
                 "__doc__": f"ProgPy's ``progpy.models.{name}`` as a white box "
                            f"(see :mod:`graybox.models.progpy`)."}
    return type(name, (ProgPyModel,), namespace)


def __getattr__(name: str):
    # graybox.models.progpy:<Name> resolves to the catalogue model's white box
    if name.startswith("_") or not name[:1].isupper():
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return catalogue_model(name)
