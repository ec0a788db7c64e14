"""ProgPy prognostics models (NASA's ``progpy``) as white boxes.

Any :class:`progpy.PrognosticsModel` becomes a :class:`~graybox.models.base.WhiteBoxModel`:

- a model of ProgPy's catalogue by name, ``graybox.models.progpy:<Name>`` for every
  ``progpy.models.<Name>`` (``CentrifugalPump``, ``BatteryCircuit``, ``PneumaticValve``,
  ``ThrownObject``, ...);
- any other ProgPy model by a two-line subclass of :class:`ProgPyModel` naming it::

      class MyPump(ProgPyModel):
          progpy_model = "mypackage.models:MyPump"

**Variables.** The white box's inputs are the ProgPy model's inputs and its outputs the
ProgPy outputs, predicted by ProgPy's own ``output(x)``. A ProgPy state named like an output
(the pump's ``w``), or named in the column map (``columns = {Q = "Qout"}`` reads the pump's
flow ``Q`` from the column ``Qout``, which then stands for that state and not for the output of
the same name), is measured. The other states are of two kinds:

- *hidden*: states with dynamics of their own (a battery's charge ``qb`` and RC charges), run
  through each window by ProgPy's dynamics from a start estimated from the data
  (:mod:`graybox.state_estimation`), like any white box's hidden states;
- *held* at their parameter ``x0_<state>`` (default: the ProgPy model's ``parameters["x0"]``,
  0 where it has none): the *constant* states, which do not move while the held states keep
  their values (wear rates, and the impeller area and friction coefficients they drive:
  slow damage, which the residual is to show as a fault, not follow), and the *algebraic*
  states of a discrete model, which ``next_state`` sets afresh from the inputs (the pump's
  ``QLeak``) and which have no derivative to integrate. Both are found once per class by
  probing the ProgPy model at perturbed states and inputs (:func:`held_states`); a subclass
  may list its own in ``held``.

**Parameters.** Every scalar numeric ProgPy parameter (``I``, ``r``, ``c``, ... for the
pump) is a white-box parameter of the same name, overridable in ``fleet.toml``; noise
parameters, nested tables and parameters that a state of the same name overrides are not.
Two more kinds: ``x0_<state>`` (the value a held state keeps, and where the search for a
hidden state's start begins) and, for a discrete model, ``derivative_step``.

**Dynamics.** A continuous model (one defining ``dx``) gives the derivatives directly. A
discrete model (one defining only ``next_state``) is differentiated as
``(next_state(x, u, h) - x) / h`` with ``h = derivative_step`` seconds: exact for the
Euler-form transitions of ProgPy's catalogue (``x + xdot * dt``, e.g. ``CentrifugalPump``),
a first-order approximation otherwise. The residual then integrates these derivatives as it
does a built-in model's (:mod:`graybox.integration`). No noise is applied: the process and measurement
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
#: perturbed states and inputs at which :func:`held_states` probes a ProgPy model
PROBES = 4
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


@functools.cache
def _read_once(container: type, constants: bool = False) -> type:
    """``container`` (a ProgPy model's ``StateContainer`` or ``InputContainer``) whose items
    are the same rows, taken from its matrix at the first read: ProgPy finds a key's row with
    ``list.index`` on every read, and a model's ``next_state`` reads each variable many
    times (a third to a half of a pump's ``next_state`` call). Writing an item, deleting one
    or setting the matrix (``x.matrix += ...``, as ``DCMotor`` does) takes the rows again; a
    model that wrote into a row in place and then read that variable would read the old
    value (ProgPy's catalogue does not: ``DCMotor`` wraps its angle last). With
    ``constants`` (inputs) a row of one value throughout is read as that value, as a batch of
    one sample's is: a model that builds an array from an input it expects to be a number
    (``CentrifugalPump``'s leak flow from its pressures) then takes a batch in which other
    inputs vary."""

    class ReadOnce(container):
        _rows = None

        def __getitem__(self, key):
            if self._rows is None:
                self._rows = {k: (row[0] if len(row) == 1 or (constants and np.all(row == row[0]))
                                  else row)
                              for k, row in zip(self._keys, self._matrix)}
            return self._rows[key]

        def __setitem__(self, key, value):
            self._rows = None
            super().__setitem__(key, value)

        def __delitem__(self, key):
            self._rows = None
            super().__delitem__(key)

        @property
        def matrix(self):
            return self._matrix

        @matrix.setter
        def matrix(self, value):
            self._rows = None
            self._matrix = value

    ReadOnce.__name__ = ReadOnce.__qualname__ = f"ReadOnce{container.__name__}"
    return ReadOnce


def progpy_rates(model, full: np.ndarray, inputs: np.ndarray, step: float) -> np.ndarray:
    """ProgPy's ``dx`` of a continuous model, ``(next_state(x, u, step) - x) / step`` of a
    discrete one, at the state columns ``full`` (n_states, T) and inputs (n_inputs, T)."""
    state = _read_once(model.StateContainer)(full.copy())
    load = _read_once(model.InputContainer, constants=True)(inputs.copy())
    if not model.is_discrete:
        return np.asarray(model.dx(state, load).matrix, dtype=float).reshape(full.shape)
    following = np.asarray(model.next_state(state, load, step).matrix, dtype=float)
    return (following.reshape(full.shape) - full) / step


def held_states(model, held_values: np.ndarray, step: float = DEFAULT_DERIVATIVE_STEP,
                seed: int = 0) -> tuple[str, ...]:
    """The states of a ProgPy model that the white box holds at ``held_values``.

    *Algebraic* states of a discrete model (``next_state`` gives a value that does not depend
    on the state's current one) and *constant* states: those whose rate is zero at every
    probe, the states already found constant held at their values and the rest perturbed.
    The search repeats until no more states join, so a wear rate (constant) makes the
    area it wears (constant while the rate is held at 0) constant too.

    Parameters
    ----------
    model : progpy.PrognosticsModel
    held_values : ndarray (n_states,)
        Each state's typical value (``x0``).
    step : float
        The derivative step of a discrete model.
    seed : int
        Seeds the probes (:data:`PROBES` perturbations of the states and inputs).
    """
    rng = np.random.default_rng(seed)
    states = tuple(model.states)
    n = len(states)
    probes = (held_values[:, None] * (1 + 0.3 * rng.standard_normal((n, PROBES)))
              + 0.3 * rng.standard_normal((n, PROBES)))
    inputs = 1.0 + rng.standard_normal((len(model.inputs), PROBES))

    def each_probe(function, at: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            return np.concatenate([function(at[:, [k]], inputs[:, [k]])
                                   for k in range(PROBES)], axis=1)

    def rates(at, load):
        return progpy_rates(model, at, load, step)

    def following(at, load):
        return np.asarray(model.next_state(model.StateContainer(at.copy()),
                                           model.InputContainer(load.copy()), step).matrix,
                          dtype=float).reshape(at.shape)

    held = np.zeros(n, dtype=bool)
    if model.is_discrete:
        base = each_probe(following, probes)
        for j in range(n):
            nudged = probes.copy()
            nudged[j] += 0.1 * np.maximum(1.0, np.abs(probes[j]))
            held[j] = np.array_equal(each_probe(following, nudged)[j], base[j])
    while True:
        at = np.where(held[:, None], held_values[:, None], probes)
        still = np.all(each_probe(rates, at) == 0.0, axis=1) | held
        if np.array_equal(still, held):
            return tuple(s for s, h in zip(states, held) if h)
        held = still


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
        All ProgPy states, measured, hidden or held.
    held : tuple of str
        The ProgPy states held at ``x0_<state>`` unless measured (class attribute).
    states : tuple of str
        The measured and hidden states (instance attribute), in ProgPy's order.
    outputs : tuple of str
        The measured states, then the ProgPy outputs computed by ``output(x)`` (instance
        attribute).
    """

    progpy_model: ClassVar[str] = ""
    progpy_states: ClassVar[tuple[str, ...]] = ()
    progpy_outputs: ClassVar[tuple[str, ...]] = ()
    progpy_parameters: ClassVar[tuple[str, ...]] = ()
    #: ProgPy states held at their ``x0_<state>`` when not measured (found by
    #: :func:`held_states` unless a subclass lists them)
    held: ClassVar[tuple[str, ...] | None] = None

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
        # the class-level states and outputs (checked by WhiteBoxModel) are all ProgPy's;
        # each instance narrows the states to the measured and hidden ones
        cls.states = states
        cls.outputs = tuple(o for o in cls.progpy_outputs if o not in cls.inputs)
        parameters = _scalar_parameters(default.parameters, states)
        for name in _derived_parameters(progpy_class, default):
            parameters.pop(name, None)
        cls.progpy_parameters = tuple(parameters)
        parameters.update(_hold_defaults(default.parameters, states))
        if default.is_discrete:
            parameters["derivative_step"] = DEFAULT_DERIVATIVE_STEP
        cls.default_parameters = parameters
        cls._progpy_class = progpy_class
        if "held" in cls.__dict__:
            unknown = sorted(set(cls.held or ()) - set(states))
            if unknown:
                raise ModelSpecError(f"{cls.__qualname__}.held names {unknown}, which are not "
                                     f"states of {cls.progpy_model}")
            cls.held = tuple(cls.held or ())
        else:
            values = np.array([parameters[HOLD_PREFIX + s] for s in states])
            try:
                cls.held = held_states(default, values)
            except Exception:  # a model that cannot run at the probes: a subclass lists them
                cls.held = ()

    def __init__(self, parameters: Mapping[str, float] | None = None,
                 columns: Mapping[str, str] | None = None):
        if type(self)._abstract:
            raise ModelSpecError(f"{type(self).__name__} is an abstract model base; subclass it")
        columns = dict(columns or {})
        variables = self.progpy_states + self.progpy_outputs + self.inputs
        unknown = [n for n in columns if n not in variables]
        if unknown:
            raise ModelSpecError(
                f"{self.spec()}: column map names {unknown}, which are not ProgPy states, "
                f"outputs or inputs; states: {', '.join(self.progpy_states)}; outputs: "
                f"{', '.join(self.progpy_outputs)}; inputs: {', '.join(self.inputs) or '(none)'}")
        measured = tuple(s for s in self.progpy_states
                         if s in self.progpy_outputs or s in columns)
        taken = {columns.get(s, s) for s in measured}
        computed = tuple(o for o in self.progpy_outputs
                         if o not in self.progpy_states and columns.get(o, o) not in taken)
        if not measured + computed:
            raise ModelSpecError(
                f"{self.spec()}: the model predicts no telemetry channel: it has no ProgPy "
                f"outputs; map at least one state to its telemetry column in 'columns' "
                f"(states: {', '.join(self.progpy_states)})")
        for name in parameters or {}:
            if name in self.progpy_states and name not in self.default_parameters:
                raise ModelSpecError(
                    f"{self.spec()}: {name!r} is a ProgPy state of this model, not a parameter; "
                    f"the value it is held at (or its hidden start's guess) is the parameter "
                    f"'{HOLD_PREFIX}{name}'")
        self.states = tuple(s for s in self.progpy_states
                            if s in measured or s not in self.held)
        self.outputs = measured + computed
        super().__init__(parameters, columns)
        overrides = {name: self.parameters[name] for name in self.progpy_parameters
                     if self.parameters[name] != self.default_parameters[name]}
        self.progpy_overrides: dict[str, float] = overrides
        self.progpy = self.make_progpy()
        self.initial_state = {s: self.parameters[HOLD_PREFIX + s] for s in self.hidden_states}
        self._state_rows = np.array([self.progpy_states.index(s) for s in self.states])
        self._held = np.array([self.parameters[HOLD_PREFIX + s] for s in self.progpy_states])
        self._measured_outputs = np.array([self.states.index(o) for o in measured], dtype=int)
        self._computed_rows = np.array([self.progpy_outputs.index(o) for o in computed],
                                       dtype=int)
        #: per input, whether ProgPy takes a batch in which it varies (None: no batch with
        #: varying inputs seen yet; :meth:`_inputs_free_in_a_batch`)
        self._free_inputs: np.ndarray | None = None

    @functools.cached_property
    def diagnosable(self) -> tuple[str, ...]:
        """The fault hypotheses' parameters (:func:`graybox.diagnosis.candidate_hypotheses`):
        the values of the held states that change the white box's dynamics. ProgPy models
        damage as states (a pump's impeller area and bearing friction coefficients), which the
        white box holds; a held wear rate moves nothing while the area it wears is held too,
        and ProgPy's physical constants are not faults. Found by probing the derivatives at
        :data:`PROBES` perturbed states and inputs with each held value changed by 10 %; empty
        (every number parameter is then a hypothesis) when no held value matters."""
        from graybox.parameter_estimation import with_parameters   # it imports the models

        held = [s for s in self.progpy_states if s not in self.states]
        if not held:
            return ()
        rng = np.random.default_rng(0)
        typical = np.array([self.parameters[HOLD_PREFIX + s] for s in self.states])
        x = typical * (1 + 0.05 * rng.standard_normal((PROBES, len(self.states))))
        u = 1.0 + rng.standard_normal((PROBES, len(self.inputs)))
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            base = self.derivatives(x, u)
            names = []
            for state in held:
                name = HOLD_PREFIX + state
                value = self.parameters[name]
                changed = with_parameters(self, {name: 1.1 * value + 0.1}).derivatives(x, u)
                if np.any(np.isfinite(changed) & np.isfinite(base) & (changed != base)):
                    names.append(name)
        return tuple(names)

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
        """ProgPy state matrix (n_progpy_states, T): measured and hidden rows from ``x``
        (T, n_states), the held ones at their ``x0_<state>`` parameters."""
        x = np.asarray(x, dtype=float)
        full = np.repeat(self._held[:, None], len(x), axis=1)
        full[self._state_rows] = x.T
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
        return rates[self._state_rows].T

    def output(self, x, u):
        """The measured states as they are, the other outputs by ProgPy's ``output(x)``."""
        x = np.asarray(x, dtype=float)
        y = np.empty((len(x), len(self.outputs)))
        y[:, :len(self._measured_outputs)] = x[:, self._measured_outputs]
        if self._computed_rows.size:
            full = self.full_state(x)
            if self.progpy.is_vectorized:
                z = self._progpy_outputs(full)
            else:
                z = np.concatenate([self._progpy_outputs(full[:, [t]])
                                    for t in range(full.shape[1])], axis=1)
            y[:, len(self._measured_outputs):] = z[self._computed_rows].T
        return y

    def _progpy_outputs(self, full: np.ndarray) -> np.ndarray:
        state = _read_once(self.progpy.StateContainer)(full.copy())
        values = np.asarray(self.progpy.output(state).matrix, dtype=float)
        return values.reshape(len(self.progpy_outputs), full.shape[1])

    def _vectorised_rates(self, full: np.ndarray, u: np.ndarray) -> np.ndarray:
        varies = np.any(u != u[:1], axis=0)
        if not varies.any():
            return self._progpy_rates(full, u[:1].T)
        if self._free_inputs is None:
            self._free_inputs = self._inputs_free_in_a_batch(full, u)
        key = varies & ~self._free_inputs
        if not key.any():
            return self._progpy_rates(full, u.T)
        # One batch per distinct value of the inputs a batch may not vary in: some vectorised
        # ProgPy models fail (or, worse, build a T x T matrix) when those vary within a batch
        # (CentrifugalPump's leak flow, from the two pressures; its voltage may vary).
        distinct, which = np.unique(u[:, key], axis=0, return_inverse=True)
        which = which.reshape(-1)
        order = np.argsort(which, kind="stable")
        bounds = np.cumsum(np.bincount(which, minlength=len(distinct)))[:-1]
        rates = np.empty_like(full)
        for columns in np.split(order, bounds):
            rates[:, columns] = self._progpy_rates(full[:, columns], u[columns].T)
        return rates

    def _inputs_free_in_a_batch(self, full: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Per input, whether a batch in which it varies gives the per-sample rates: probed
        on the first batch whose inputs vary, on up to 3 of its samples with distinct values
        of that input and every other input as in the first of them; then the free inputs
        varying together (all held to a batch of one value each if that fails). An input
        that does not vary in that batch cannot be probed and is held."""
        free = np.zeros(u.shape[1], dtype=bool)
        for column in np.flatnonzero(np.any(u != u[:1], axis=0)):
            _, first = np.unique(u[:, column], return_index=True)
            probe = np.sort(first)[:3]
            inputs = np.repeat(u[probe[:1]], len(probe), axis=0)
            inputs[:, column] = u[probe, column]
            free[column] = self._takes_a_batch(full[:, probe], inputs)
        if np.count_nonzero(free) > 1:
            _, first = np.unique(u[:, free], axis=0, return_index=True)
            probe = np.sort(first)[:3]
            inputs = np.repeat(u[probe[:1]], len(probe), axis=0)
            inputs[:, free] = u[np.ix_(probe, free)]
            if not self._takes_a_batch(full[:, probe], inputs):
                free[:] = False
        return free

    def _takes_a_batch(self, full: np.ndarray, inputs: np.ndarray) -> bool:
        """Whether ProgPy's rates of these samples (states ``full`` (n, k), ``inputs``
        (k, n_inputs)) in one batch are those it gives each sample alone."""
        alone = np.concatenate([self._progpy_rates(full[:, [t]], inputs[[t]].T)
                                for t in range(full.shape[1])], axis=1)
        try:
            together = self._progpy_rates(full, inputs.T)
        except (ValueError, TypeError, IndexError):
            return False
        if together.shape != alone.shape:
            return False
        # each state to 1e-12 of its largest rate: a rate of 0 alone may be 1e-18 together
        scale = np.nanmax(np.abs(alone), axis=1, keepdims=True, initial=0.0)
        same = (np.abs(together - alone) <= 1e-12 * scale) | (np.isnan(together) & np.isnan(alone))
        return bool(np.all(same))

    def _progpy_rates(self, full: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        return progpy_rates(self.progpy, full, inputs,
                            self.parameters.get("derivative_step", DEFAULT_DERIVATIVE_STEP))

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
