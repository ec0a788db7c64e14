"""graybox: the gray-box method of model-based fault diagnosis (the pure science core).

A physics model filters telemetry into a residual (the white box); the residual is described
by an AR tier, a time-delay tanh network and the noise's moments (the black box); faults show
as drift (zeta) of those parameters from the asset's healthy baseline.

>>> import graybox as gb                                                   # doctest: +SKIP
>>> model = gb.load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})
>>> days = gb.read_window("telemetry", "T-001", model.required_columns).split("1D")
>>> baseline = gb.GrayBox(model).fit(days[:4])                 # signature_ + calibration_
>>> drift = baseline.drift(days[5])                            # refit with frozen structure
>>> [(a.channel, a.tier, a.zeta, a.epsilon) for a in drift.alarms]

This package imports numpy, scipy, pandas, pyarrow, threadpoolctl and torch only: never mlflow
or prefect.
"""
from graybox.calibration import Calibration
from graybox.decompose import decompose
from graybox.diagnosis import Diagnosis, Hypothesis, diagnose
from graybox.drift import Drift, compute_drift
from graybox.estimator import FitRequest, GrayBox, GrayBoxSettings, fit_baselines, fit_signatures
from graybox.exceptions import (ArtifactError, GrayBoxError, InsufficientDataError,
                                InvalidAssetIdError, ModelSpecError, StructureMismatchError,
                                TelemetryError)
from graybox.models import WhiteBoxModel, load_model
from graybox.parameter_estimation import ParameterEstimate, estimate_parameters
from graybox.residual import residual_frame
from graybox.signature import TIERS, Signature
from graybox.telemetry import GridPolicy, TelemetryWindow, read_window

__all__ = [
    "GrayBox", "GrayBoxSettings", "FitRequest", "fit_signatures", "fit_baselines",
    "Signature", "Calibration", "Drift", "compute_drift", "decompose", "TIERS",
    "WhiteBoxModel", "load_model", "residual_frame",
    "estimate_parameters", "ParameterEstimate", "diagnose", "Diagnosis", "Hypothesis",
    "read_window", "GridPolicy", "TelemetryWindow",
    "GrayBoxError", "ModelSpecError", "TelemetryError", "InsufficientDataError",
    "StructureMismatchError", "ArtifactError", "InvalidAssetIdError",
]
