"""One live instance of an FMI 2.0 model-exchange FMU, evaluated row by row.

:class:`FMUInstance` is what :class:`graybox.models.fmu.FMUModel` calls: it instantiates the
FMU with FMPy (``fmpy.fmi2.FMU2Model``), sets the parameters before initialisation, runs the
FMI 2.0 initialisation sequence up to continuous-time mode at time 0, and then evaluates the
derivatives and outputs at each row of states and inputs: ``fmi2SetReal`` of the inputs,
``fmi2SetContinuousStates``, ``fmi2GetDerivatives`` or ``fmi2GetReal``. FMI evaluates one
instant per call, so a window is a loop over its rows; the loop calls the FMU's C functions
through ctypes prototypes of their own (addresses in, status out), not through FMPy's
per-call wrappers, which check and log each call (docs/design.md, "FMUs", has the cost).

A row whose states or inputs are not finite is left NaN without calling the FMU (a gap in the
telemetry stays a gap). A row the FMU refuses (status discard or error) is NaN too, for the
residual to report where (:func:`graybox.integration.check_finite_derivatives`); after an
error the instance is made afresh, as FMI 2.0 leaves an instance undefined after one. A fatal
status is a :class:`~graybox.exceptions.ModelSpecError`.

FMPy is imported by the caller (:mod:`graybox.models.fmu`) and handed in.
"""
from __future__ import annotations

import collections
import ctypes
import threading
import weakref
from dataclasses import dataclass

import numpy as np

from graybox.exceptions import ModelSpecError

_STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")
_DISCARD, _FATAL = 2, 4
#: FMU log messages kept for an error's text
_KEPT_MESSAGES = 5
#: FMPy's FMU2Model changes the process's working directory while it loads the library and
#: changes it back: two loads at once in two threads could leave it changed for good
_LOADING_LIBRARY = threading.Lock()
# fmi2SetContinuousStates / fmi2GetDerivatives: (component, double*, size_t)
_STATE_CALL = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t)
# fmi2SetReal / fmi2GetReal: (component, unsigned int*, size_t, double*)
_VALUE_CALL = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t,
                               ctypes.c_void_p)


@dataclass(frozen=True)
class FMUInterface:
    """What an FMU's model description declares, as the white box uses it.

    Attributes
    ----------
    path : str
        The ``.fmu`` file (for messages).
    unzipped : str
        Where it is extracted.
    guid, model_identifier : str
        From its model description.
    state_count : int
        Continuous states (the derivatives' order is the state vector's).
    input_references, output_references : tuple of int
        Value references of the real inputs and of the outputs computed by ``fmi2GetReal``.
    parameter_references : tuple of int
        Value references of the real parameters, in the white box's parameter order.
    input_starts : tuple of float
        The inputs' start values (0 where none), where the start is checked.
    """

    path: str
    unzipped: str
    guid: str
    model_identifier: str
    state_count: int
    input_references: tuple[int, ...]
    output_references: tuple[int, ...]
    parameter_references: tuple[int, ...]
    input_starts: tuple[float, ...]


class FMUInstance:
    """An instantiated, initialised FMU in continuous-time mode at time 0.

    Parameters
    ----------
    fmpy : module
        ``fmpy``, with ``fmpy.fmi2`` imported.
    interface : FMUInterface
    parameters : tuple of float
        Values of ``interface.parameter_references``, set before initialisation.

    Raises
    ------
    ModelSpecError
        If the FMU cannot be loaded, rejects the parameters, fails to initialise, or its
        derivatives at its own start state and start inputs are not finite.
    """

    def __init__(self, fmpy, interface: FMUInterface, parameters: tuple[float, ...]):
        self.interface = interface
        self.parameters = parameters
        self._fmi2 = fmpy.fmi2
        self._call_failed = fmpy.fmi1.FMICallException   # FMPy's error of a failed FMI call
        self._lock = threading.Lock()
        self._messages: collections.deque = collections.deque(maxlen=_KEPT_MESSAGES)
        self._inputs = np.array(interface.input_references, dtype=np.uint32)
        self._outputs = np.array(interface.output_references, dtype=np.uint32)
        self._instantiate()
        start = np.empty((1, interface.state_count))
        if self._get_states(self._component, start.ctypes.data, interface.state_count) >= _DISCARD:
            raise ModelSpecError(f"FMU {interface.path}: fmi2GetContinuousStates failed after "
                                 f"initialisation{self._log()}")
        inputs = np.array([interface.input_starts])
        rates = self.derivatives(start, inputs)
        if not np.all(np.isfinite(rates)):
            raise ModelSpecError(
                f"FMU {interface.path}: its derivatives are {rates[0].tolist()} at its own "
                f"start state {start[0].tolist()} with the inputs at their start values "
                f"{list(interface.input_starts)}; a white box must be finite there: check the "
                f"parameters given (a zero time constant?) or the model{self._log()}")

    # -- evaluation ---------------------------------------------------------------------------
    def derivatives(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``dx/dt`` at every row of ``x`` (T, n_states) and ``u`` (T, n_inputs)."""
        return self._rows(x, u, self.interface.state_count, derivatives=True)

    def outputs(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The computed outputs (``output_references``) at every row."""
        return self._rows(x, u, len(self._outputs), derivatives=False)

    def _rows(self, x, u, columns: int, derivatives: bool) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=float)
        u = np.ascontiguousarray(u, dtype=float)
        result = np.full((len(x), columns), np.nan)
        if not columns:
            return result
        n_states, n_inputs = x.shape[1], u.shape[1]
        rows = np.flatnonzero(np.isfinite(x).all(axis=1) & np.isfinite(u).all(axis=1))
        with self._lock:
            failed = []
            first = 0
            while first < len(rows):
                first = self._evaluate(rows, first, x, u, result, derivatives, failed)
        for row in failed:
            result[row] = np.nan
        return result

    def _evaluate(self, rows, first, x, u, result, derivatives, failed) -> int:
        """Rows ``rows[first:]`` until the FMU reports an error (re-instantiated then); the
        index of the next row to evaluate."""
        component, n_states, n_inputs = self._component, x.shape[1], u.shape[1]
        set_states, set_real, get_real = self._set_states, self._set_real, self._get_real
        get_derivatives = self._get_derivatives
        inputs, outputs = self._inputs.ctypes.data, self._outputs.ctypes.data
        n_outputs = len(self._outputs)
        todo = rows[first:]
        # each row's addresses, as Python ints (ctypes takes them as pointers)
        x_rows = (x.ctypes.data + todo * (8 * n_states)).tolist()
        u_rows = (u.ctypes.data + todo * (8 * n_inputs)).tolist()
        out_rows = (result.ctypes.data + todo * (8 * result.shape[1])).tolist()
        for k, x_row, u_row, out_row in zip(range(first, len(rows)), x_rows, u_rows, out_rows):
            status = set_states(component, x_row, n_states)
            if n_inputs:
                status |= set_real(component, inputs, n_inputs, u_row)
            if derivatives:
                status |= get_derivatives(component, out_row, n_states)
            else:
                status |= get_real(component, outputs, n_outputs, out_row)
            if status >= _DISCARD:   # statuses are 0-4: the OR is >= 2 iff one of them is
                row = int(rows[k])
                failed.append(row)
                if status & _FATAL:
                    raise ModelSpecError(
                        f"FMU {self.interface.path}: a fatal error at states "
                        f"{x[row].tolist()} and inputs {u[row].tolist()}; the FMU cannot be "
                        f"used further{self._log()}")
                self._release()
                self._instantiate()
                return k + 1
        return len(rows)

    # -- life cycle ---------------------------------------------------------------------------
    def _instantiate(self) -> None:
        interface = self.interface
        messages = self._messages

        # the FMU's logger; the message's printf arguments are not read (ctypes cannot take
        # them), so a message is its template
        def log(environment, instance, status, category, message):
            label = _STATUS[status] if 0 <= status < len(_STATUS) else str(status)
            messages.append(f"[{label}] {(message or b'').decode('utf-8', 'replace')}")

        callbacks = self._fmi2.fmi2CallbackFunctions()
        callbacks.logger = self._fmi2.fmi2CallbackLoggerTYPE(log)
        callbacks.allocateMemory = self._fmi2.defaultCallbacks.allocateMemory
        callbacks.freeMemory = self._fmi2.defaultCallbacks.freeMemory
        try:
            with _LOADING_LIBRARY:
                fmu = self._fmi2.FMU2Model(guid=interface.guid,
                                           unzipDirectory=interface.unzipped,
                                           modelIdentifier=interface.model_identifier,
                                           instanceName="graybox")
        except Exception as error:   # FMPy raises Exception for a library it cannot load
            raise ModelSpecError(f"FMU {interface.path}: cannot load its binary: {error}; "
                                 f"export it for this platform") from None
        self._fmu = fmu
        try:
            fmu.instantiate(callbacks=callbacks)
        except Exception as error:   # "Failed to instantiate model" (a NULL component)
            fmu.freeLibrary()
            raise ModelSpecError(f"FMU {interface.path}: fmi2Instantiate failed ({error}); "
                                 f"is its GUID the one its binary was built with?"
                                 f"{self._log()}") from None
        self._component = fmu.component
        self._finalizer = weakref.finalize(self, _free, fmu, callbacks)
        parameters = np.array(self.parameters, dtype=float)
        references = np.array(interface.parameter_references, dtype=np.uint32)
        steps = [(lambda: fmu.fmi2SetReal(fmu.component, _pointer(references, ctypes.c_uint),
                                          len(references), _pointer(parameters, ctypes.c_double))
                  if len(references) else 0, "fmi2SetReal of the parameters"),
                 (lambda: fmu.setupExperiment(startTime=0.0), "fmi2SetupExperiment"),
                 (fmu.enterInitializationMode, "fmi2EnterInitializationMode"),
                 (fmu.exitInitializationMode, "fmi2ExitInitializationMode"),
                 (self._settle_events, "fmi2NewDiscreteStates"),
                 (fmu.enterContinuousTimeMode, "fmi2EnterContinuousTimeMode"),
                 (lambda: fmu.setTime(0.0), "fmi2SetTime")]
        for step, name in steps:
            try:
                step()
            except self._call_failed as error:
                self._release()
                raise ModelSpecError(
                    f"FMU {interface.path}: {name} failed (status "
                    f"{_STATUS[error.status] if error.status < len(_STATUS) else error.status}) "
                    f"with the parameters {list(self.parameters)}{self._log()}") from None
        self._set_states = _STATE_CALL(("fmi2SetContinuousStates", fmu.dll))
        self._get_derivatives = _STATE_CALL(("fmi2GetDerivatives", fmu.dll))
        self._set_real = _VALUE_CALL(("fmi2SetReal", fmu.dll))
        self._get_real = _VALUE_CALL(("fmi2GetReal", fmu.dll))
        self._get_states = _STATE_CALL(("fmi2GetContinuousStates", fmu.dll))

    def _settle_events(self) -> None:
        """The event iteration after initialisation (FMI 2.0 model exchange, 3.2.3)."""
        for _ in range(100):
            needed, terminate, *_ = self._fmu.newDiscreteStates()
            if terminate:
                raise ModelSpecError(f"FMU {self.interface.path}: asked to terminate at its "
                                     f"initialisation{self._log()}")
            if not needed:
                return
        raise ModelSpecError(f"FMU {self.interface.path}: its event iteration after "
                             f"initialisation did not settle in 100 steps{self._log()}")

    def _release(self) -> None:
        self._finalizer()

    def _log(self) -> str:
        if not self._messages:
            return ""
        return "; the FMU logged: " + " | ".join(self._messages)


def _pointer(array: np.ndarray, kind):
    return array.ctypes.data_as(ctypes.POINTER(kind))


def _free(fmu, callbacks) -> None:
    """Free an instance and unload its library (``callbacks`` lives until then)."""
    try:
        fmu.freeInstance()
    except Exception:  # noqa: BLE001 - at interpreter exit ctypes may be torn down first
        pass
