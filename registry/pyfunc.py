"""MLflow ``python_function`` loader for a recorded signature (no pickle anywhere).

Every model version the registry records is saved with MLflow's *loader-module* form of the
pyfunc flavour::

    mlflow.pyfunc.save_model(path, loader_module="registry.pyfunc",
                             data_path=<bundle: signature.json, calibration.json,
                                        weights.safetensors, manifest.json>)

so that ``mlflow.pyfunc.load_model("models:/fleet-health.<asset>@baseline")`` imports this
module and calls :func:`_load_pyfunc` on the bundle directory. The issue asks for the model
to be "built from JSON + tensors in ``load_context``": ``load_context`` belongs to a
``mlflow.pyfunc.PythonModel`` subclass, and MLflow stores such a class with cloudpickle,
which executes code when loaded. The loader-module form stores no Python object at all, and
the constructor of :class:`SignatureModel` plays the part of ``load_context``: it verifies
the bundle (manifest digests, no unexpected files, strict JSON with finite numbers and
shapes matching the frozen structure, tensors equal to the JSON) and rebuilds the signature
and calibration from it. It builds the white box only if the signature's model module is
already imported (:meth:`graybox.models.spec.ModelSpec.load`): a stored record never
chooses what is imported.

This module runs only when ``MLmodel`` names it. ``mlflow.pyfunc.load_model`` reads
``MLmodel`` as it finds it, so if the artifact store was rewritten to describe a pickled
``python_model``, MLflow unpickles it (running its code) and nothing here runs; and the
bundle's own manifest can be rewritten to match. The registry's own loader
(``Registry.load_pyfunc``, ``Registry.load_version``) checks the ``MLmodel`` file and pins
the manifest to the digest recorded in the registry before MLflow sees anything, so use it,
never ``mlflow.pyfunc.load_model``, on a store others can write.
"""
from __future__ import annotations

import pathlib

import numpy as np
import pandas as pd

from graybox.calibration import Calibration
from graybox.drift import compute_drift
from graybox.estimator import GrayBox
from graybox.signature import Signature
from graybox.timestamps import utc
from registry.write.artifacts import read_bundle

OUTPUT_COLUMNS = ("channel", "tier", "zeta", "epsilon", "ratio", "exceeded")


class SignatureModel:
    """A baseline signature that scores telemetry: ``predict(frame)`` gives zeta per tier.

    Parameters
    ----------
    data_path : path-like
        The bundle directory MLflow passes to :func:`_load_pyfunc`.

    Attributes
    ----------
    signature : Signature
    calibration : Calibration or None
    """

    def __init__(self, data_path: str | pathlib.Path):
        bundle = read_bundle(data_path, where=f"pyfunc bundle {pathlib.Path(data_path).name!r}")
        self.signature: Signature = bundle.signature
        self.calibration: Calibration | None = bundle.calibration
        self._model = self.signature.model.load()

    @property
    def telemetry_columns(self) -> tuple[str, ...]:
        """Columns ``predict`` needs (the white box's states and inputs)."""
        return self._model.required_columns

    def predict(self, model_input: pd.DataFrame, params: dict | None = None) -> pd.DataFrame:
        """Fit a candidate on a telemetry window against this baseline and report its drift.

        Parameters
        ----------
        model_input : pandas.DataFrame
            Uniform-grid telemetry with the model's columns (:attr:`telemetry_columns`),
            indexed by UTC timestamps or with a ``timestamp`` column, sampled every
            ``signature.sample_interval`` seconds.
        params : dict, optional
            Unused (MLflow's pyfunc signature).

        Returns
        -------
        pandas.DataFrame
            One row per (channel, tier): ``channel, tier, zeta, epsilon, ratio, exceeded``.
            ``epsilon`` and ``ratio`` are NaN when the baseline has no calibration.
        """
        frame = self._frame(model_input)
        candidate = GrayBox(self._model, baseline=self.signature).fit(frame)
        drift = compute_drift(candidate.signature_, self.signature, self.calibration)
        rows = [{"channel": e.channel, "tier": e.tier, "zeta": e.zeta,
                 "epsilon": np.nan if e.epsilon is None else e.epsilon,
                 "ratio": np.nan if e.ratio is None else e.ratio,
                 "exceeded": bool(e.exceeded)} for e in drift.entries]
        return pd.DataFrame(rows, columns=list(OUTPUT_COLUMNS))

    def _frame(self, model_input) -> pd.DataFrame:
        if not isinstance(model_input, pd.DataFrame):
            raise TypeError(f"predict expects a pandas DataFrame of telemetry, got "
                            f"{type(model_input).__name__}")
        frame = model_input
        if "timestamp" in frame.columns:
            frame = frame.set_index(pd.to_datetime(frame["timestamp"], utc=True)).drop(columns="timestamp")
        if not isinstance(frame.index, pd.DatetimeIndex):
            raise ValueError("telemetry needs a DatetimeIndex or a 'timestamp' column")
        frame = frame.set_axis(utc(frame.index).as_unit("ns"), axis=0)  # graybox reads nanosecond ticks
        frame.index.name = "timestamp"
        missing = [c for c in self.telemetry_columns if c not in frame.columns]
        if missing:
            raise ValueError(f"telemetry lacks column(s) {missing}; the model needs "
                             f"{list(self.telemetry_columns)}")
        frame = frame[list(self.telemetry_columns)].astype(float)
        if len(frame) < 2:
            raise ValueError("telemetry has fewer than 2 samples")
        steps = np.diff(frame.index.asi8) / 1e9
        expected = self.signature.sample_interval
        if not np.allclose(steps, expected, rtol=1e-6, atol=1e-9):
            bad = int(np.argmax(~np.isclose(steps, expected, rtol=1e-6, atol=1e-9)))
            raise ValueError(f"telemetry is not on the baseline's uniform grid of {expected:g} s "
                             f"(step {steps[bad]:g} s after row {bad}); grid it first "
                             f"(graybox.telemetry.to_grid)")
        values = frame.to_numpy()
        if not np.isfinite(values).all():
            row = int(np.argwhere(~np.isfinite(values))[0][0])
            raise ValueError(f"telemetry has a NaN or infinite value at row {row}")
        return frame


def _load_pyfunc(data_path: str) -> SignatureModel:
    """MLflow's entry point for the loader-module pyfunc form (see the module docstring)."""
    return SignatureModel(data_path)
