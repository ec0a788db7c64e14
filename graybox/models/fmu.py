"""FMUs (FMI 2.0, model exchange) as white boxes, through FMPy.

A plant model exported from Modelica, Simulink or another FMI tool as a *model-exchange* FMU
becomes a :class:`~graybox.models.base.WhiteBoxModel` by a two-line subclass that names the
file::

    from graybox.models.fmu import FMUModel

    class CoolingLoop(FMUModel):
        fmu = "cooling_loop.fmu"     # relative to this module's file, or absolute

and fleet.toml names the class as any white box (``model = "myplants.cooling:CoolingLoop"``),
with ``parameters`` overriding the FMU's parameters and ``columns`` mapping its variables to
telemetry columns. A worker process (Dask, the nightly compute pool) rebuilds the model by
importing the class, which holds the path, never a live FMU; pickling sends the class's name,
the parameters and the columns.

**Variables.** The white box's names are the FMU's variable names with every character that
is not a letter, digit or underscore replaced by ``_`` (``heater.T`` is ``heater_T``,
``x[1]`` is ``x_1_``):

- ``states``: the continuous states, in the order of the model description's
  ``<Derivatives>`` (the FMU's state vector);
- ``inputs``: the variables of causality ``input`` and type Real (inputs of other types keep
  their start values);
- ``outputs``: the variables of causality ``output`` and type Real. An output that is a
  state (the same value reference) is that state, measured; the others are computed by
  ``fmi2GetReal``. States that are not outputs are hidden, estimated from the data
  (:mod:`graybox.state_estimation`), their search starting at their start values
  (``initial_state``). An FMU without outputs has every state measured;
- ``default_parameters``: the Real variables of causality ``parameter`` (variability
  ``fixed`` or ``tunable``) that have a start value. ``positive`` are those of them whose
  declared ``min`` is >= 0 and whose start value is > 0.

**Evaluation.** The parameters are set before initialisation (``fmi2SetReal`` after
``fmi2Instantiate``), the FMU is initialised and put in continuous-time mode at time 0, and
``derivatives(x, u)`` and ``output(x, u)`` loop over the rows
(:class:`~graybox.models.fmu_instance.FMUInstance`). A model whose parameters change (a
fault hypothesis, a tuned parameter) is a new instance; an instance whose ``parameters``
were replaced afterwards is instantiated afresh on its next call. The FMU is evaluated at
time 0 throughout, and no events are handled: the continuous dynamics at each state and
input, as a white box's ``derivatives`` are (time- and event-driven FMUs are not supported).

**What is refused**, as a :class:`~graybox.exceptions.ModelSpecError` naming the file and
what to do: FMPy missing, a file that is not an FMU, FMI 1.0 or 3.0, an FMU for
co-simulation only, one without a binary for this platform, no continuous states, two
variables with the same white-box name, and derivatives that are not finite at the FMU's own
start state. FMPy is imported here only, when such a class is created.
"""
from __future__ import annotations

import copy
import importlib
import math
import os
import pathlib
import re
import shutil
import sys
import weakref
from typing import ClassVar

import numpy as np

from graybox.exceptions import ModelSpecError
from graybox.models.base import WhiteBoxModel
from graybox.models.fmu_instance import FMUInstance, FMUInterface

_INSTALL = "install it with: pip install 'fleet-health[fmu]'"
_NOT_WORD = re.compile(r"\W")


def import_fmpy():
    """``fmpy`` with ``fmpy.fmi2`` imported, or a ModelSpecError naming the extra to install."""
    try:
        fmpy = importlib.import_module("fmpy")
        importlib.import_module("fmpy.fmi2")
    except ImportError as error:
        raise ModelSpecError(f"FMU models need the fmpy package ({error}); {_INSTALL}") from None
    return fmpy


def white_box_name(variable: str) -> str:
    """The white-box name of an FMU variable: every character that is not a letter, digit or
    underscore becomes ``_`` (and a leading digit gets a ``_`` before it)."""
    name = _NOT_WORD.sub("_", variable)
    return "_" + name if name[:1].isdigit() else name


class FMUModel(WhiteBoxModel, abstract=True):
    """Base of white boxes that are an FMI 2.0 model-exchange FMU.

    A subclass sets ``fmu``, the path of the ``.fmu`` file (relative to the directory of the
    module that defines the subclass, or absolute; ``~`` is expanded). Its ``states``,
    ``inputs``, ``outputs``, ``default_parameters``, ``positive`` and ``initial_state`` are
    then read from the FMU's model description when the class is created (see the module
    docstring).

    Parameters
    ----------
    parameters : mapping of str to float, optional
        Overrides of the FMU's parameters, by white-box name.
    columns : mapping of str to str, optional
        Model variable -> telemetry column.

    Attributes
    ----------
    fmu_path : pathlib.Path
        The resolved file (class attribute).
    fmu_variables : dict of str to str
        White-box name -> FMU variable name, for every state, input, output and parameter
        (class attribute).

    Raises
    ------
    ModelSpecError
        From class creation, if the FMU cannot be used (module docstring); from
        instantiation, if the FMU rejects the parameters or its derivatives are not finite
        at its start.
    """

    fmu: ClassVar[str] = ""
    fmu_path: ClassVar[pathlib.Path]
    fmu_variables: ClassVar[dict[str, str]] = {}
    _interface: ClassVar[FMUInterface]
    _measured_rows: ClassVar[tuple[int, ...]] = ()
    _measured_columns: ClassVar[tuple[int, ...]] = ()
    _computed_columns: ClassVar[tuple[int, ...]] = ()

    def __init_subclass__(cls, abstract: bool = False, **kwargs):
        if not abstract:
            cls._declare_from_fmu()
        super().__init_subclass__(abstract=abstract, **kwargs)

    @classmethod
    def _declare_from_fmu(cls) -> None:
        fmpy = import_fmpy()
        path = _resolve(cls)
        where = cls._where(path)
        try:
            description = fmpy.read_model_description(str(path))
        except Exception as error:  # noqa: BLE001 - FMPy raises Exception, ValidationError, ...
            raise ModelSpecError(f"{where}: cannot read its modelDescription.xml ({error}); is "
                                 f"it an FMU?") from None
        if description.fmiVersion != "2.0":
            raise ModelSpecError(f"{where} is FMI {description.fmiVersion}; only FMI 2.0 "
                                 f"model exchange is supported: export it as FMI 2.0 for model "
                                 f"exchange")
        if description.modelExchange is None:
            which = (" (it is for co-simulation only: it integrates itself with its own solver)"
                     if description.coSimulation is not None else "")
            raise ModelSpecError(f"{where} is not for model exchange{which}; the white box "
                                 f"needs the derivatives at any state: export it for model "
                                 f"exchange")
        platforms = fmpy.supported_platforms(str(path))
        if fmpy.platform not in platforms:
            raise ModelSpecError(f"{where} has no binary for {fmpy.platform} (it has: "
                                 f"{', '.join(platforms) or 'none'}); export it with a "
                                 f"{fmpy.platform} binary")
        variables = description.modelVariables
        states = [unknown.variable.derivative for unknown in description.derivatives]
        unlinked = [u.variable.name for u, s in zip(description.derivatives, states) if s is None]
        if unlinked:
            raise ModelSpecError(f"{where}: its <Derivatives> list {unlinked}, which are not the "
                                 f"derivative of a state (no derivative attribute); the model "
                                 f"description is malformed: export it again")
        if not states:
            raise ModelSpecError(f"{where} has no continuous states; a white box needs at "
                                 f"least one")
        reals = [v for v in variables if v.type == "Real"]
        inputs = [v for v in reals if v.causality == "input"]
        outputs = [v for v in reals if v.causality == "output"]
        parameters = [v for v in reals if v.causality == "parameter"
                      and v.variability in ("fixed", "tunable") and v.start is not None]
        names: dict[str, str] = {}
        for variable in states + inputs + outputs + parameters:
            name = white_box_name(variable.name)
            if names.setdefault(name, variable.name) != variable.name:
                raise ModelSpecError(f"{where}: the variables {names[name]!r} and "
                                     f"{variable.name!r} both have the white-box name "
                                     f"{name!r}")
        state_references = [s.valueReference for s in states]
        cls.states = tuple(white_box_name(s.name) for s in states)
        cls.inputs = tuple(white_box_name(v.name) for v in inputs)
        cls.outputs = tuple(cls.states[state_references.index(v.valueReference)]
                            if v.valueReference in state_references else white_box_name(v.name)
                            for v in outputs) or cls.states   # none: every state measured
        cls._measured_rows = tuple(cls.states.index(o) for o in cls.outputs if o in cls.states)
        cls._measured_columns = tuple(i for i, o in enumerate(cls.outputs) if o in cls.states)
        computed = [v for v in outputs if v.valueReference not in state_references]
        cls._computed_columns = tuple(i for i, o in enumerate(cls.outputs)
                                      if o not in cls.states)
        defaults = {white_box_name(v.name): _start(v, where) for v in parameters}
        cls.default_parameters = defaults
        cls.positive = tuple(white_box_name(v.name) for v in parameters
                             if v.min is not None and float(v.min) >= 0 and _start(v, where) > 0)
        cls.initial_state = {white_box_name(s.name): _start(s, where) for s in states
                             if s.start is not None}
        cls.fmu_path = path
        cls.fmu_variables = dict(names)
        cls._interface = FMUInterface(
            str(path), _extract(fmpy, path, cls), description.guid,
            description.modelExchange.modelIdentifier, len(states),
            tuple(v.valueReference for v in inputs), tuple(v.valueReference for v in computed),
            tuple(v.valueReference for v in parameters),
            tuple(_start(v, where) if v.start is not None else 0.0 for v in inputs))

    @classmethod
    def _where(cls, path: pathlib.Path) -> str:
        """How the errors of class creation name the FMU."""
        return f"FMU {path} ({cls.__qualname__}.fmu)"

    @classmethod
    def fingerprint(cls) -> str:
        """The FMU's GUID: a re-exported or replaced FMU is another model."""
        return f"fmi2 guid {cls._interface.guid}"

    # -- instances ----------------------------------------------------------------------------
    def check_parameters(self) -> None:
        """Instantiate and initialise the FMU with these parameters: the FMU checks them."""
        self._instance = FMUInstance(import_fmpy(), self._interface,
                                     self._parameter_values())

    def _parameter_values(self) -> tuple[float, ...]:
        values = []
        for name in self.default_parameters:
            value = self.parameters[name]
            if np.ndim(value) != 0:
                raise ModelSpecError(f"{self.spec()}: an FMU white box evaluates one parameter "
                                     f"set at a time; parameter {name!r} is an array")
            values.append(float(value))
        return tuple(values)

    def _live(self) -> FMUInstance:
        """The instance for the current parameters (made afresh if they were replaced)."""
        values = self._parameter_values()
        instance = self.__dict__.get("_instance")
        if instance is None or instance.parameters != values:
            instance = FMUInstance(import_fmpy(), self._interface, values)
            self._instance = instance
        return instance

    def derivatives(self, x, u):
        (flat_x, shape), (flat_u, _) = _rows(x, len(self.states)), _rows(u, len(self.inputs))
        return self._live().derivatives(flat_x, flat_u).reshape(shape + (len(self.states),))

    def output(self, x, u):
        """The measured states as they are, the other outputs by ``fmi2GetReal``."""
        (flat_x, shape), (flat_u, _) = _rows(x, len(self.states)), _rows(u, len(self.inputs))
        y = np.empty((len(flat_x), len(self.outputs)))
        y[:, list(self._measured_columns)] = flat_x[:, list(self._measured_rows)]
        if self._computed_columns:
            y[:, list(self._computed_columns)] = self._live().outputs(flat_x, flat_u)
        return y.reshape(shape + (len(self.outputs),))

    # -- copies and pickles: never a live FMU ---------------------------------------------------
    def __copy__(self):
        twin = type(self).__new__(type(self))
        twin.__dict__.update(self.__dict__)   # shares the instance until a parameter changes
        return twin

    def __deepcopy__(self, memo):
        return type(self)(copy.deepcopy(dict(self.parameters), memo), dict(self.columns))

    def __reduce__(self):
        return type(self), (dict(self.parameters), dict(self.columns))


def _rows(values, columns: int) -> tuple[np.ndarray, tuple[int, ...]]:
    """``values`` as rows of ``columns`` and the shape of its leading axes."""
    values = np.asarray(values, dtype=float)
    shape = values.shape[:-1] if values.ndim else ()
    return values.reshape(-1, columns), shape


def _start(variable, where: str) -> float:
    value = float(variable.start)
    if not math.isfinite(value):
        raise ModelSpecError(f"{where}: the start value of {variable.name!r} is {value}")
    return value


def _resolve(cls) -> pathlib.Path:
    if not cls.fmu:
        raise ModelSpecError(f"{cls.__qualname__}.fmu must name the .fmu file (relative to "
                             f"its module's file, or absolute)")
    path = pathlib.Path(os.path.expanduser(str(cls.fmu)))
    if not path.is_absolute():
        module_file = getattr(sys.modules.get(cls.__module__), "__file__", None)
        if module_file is None:
            raise ModelSpecError(f"{cls.__qualname__}.fmu is the relative path {cls.fmu!r} "
                                 f"but module {cls.__module__!r} has no file to resolve it "
                                 f"against; give an absolute path")
        path = pathlib.Path(module_file).parent / path
    path = path.resolve()
    if not path.is_file():
        raise ModelSpecError(f"{cls.__qualname__}.fmu: no file {path}")
    return path


def _extract(fmpy, path: pathlib.Path, cls) -> str:
    """The FMU extracted to a temporary directory, removed when the class goes (at exit) by
    the process that extracted it."""
    unzipped = fmpy.extract(str(path))
    weakref.finalize(cls, _remove, unzipped, os.getpid())
    return unzipped


def _remove(directory: str, owner: int) -> None:
    if os.getpid() == owner:   # a forked child does not remove its parent's copy
        shutil.rmtree(directory, ignore_errors=True)
