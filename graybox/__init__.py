"""graybox: the gray-box method of model-based fault diagnosis (the pure science core).

A physics model filters telemetry into a residual (the white box); the residual is described
by an AR tier, a time-delay tanh network and the noise's moments (the black box); faults show
as drift (zeta) of those parameters from the asset's healthy baseline.

>>> import graybox as gb                                                   # doctest: +SKIP
>>> model = gb.load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})
>>> days = gb.read_window("telemetry", "T-001", model.required_columns).split("1D")
>>> baseline = gb.GrayBox(model).fit(days[:4])                 # signature_ + calibration_
>>> drift = baseline.drift(days[5])                            # refit with frozen structure
>>> print(drift.summary())                                    # zeta, epsilon, alarms

The tiers can also be run by hand on any residual: ``choose_differencing``, ``fit_ar``
(Yule-Walker), ``choose_delay`` and ``choose_dimension`` (Takens embedding), ``lagged`` and
``fit_networks`` (the tanh network), ``describe_noise`` (moments, Ljung-Box) and ``fit_level``.

This package imports numpy, scipy, pandas, pyarrow, threadpoolctl and torch only: never mlflow
or prefect.
"""
from typing import TYPE_CHECKING

from graybox.calibration import Calibration
from graybox.decompose import decompose
from graybox.drift import Drift, compute_drift
from graybox.embedding import choose_delay, choose_dimension
from graybox.estimator import FitRequest, GrayBox, GrayBoxSettings, fit_baselines, fit_signatures
from graybox.exceptions import (ArtifactError, GrayBoxError, InsufficientDataError,
                                InvalidAssetIdError, ModelSpecError, StructureMismatchError,
                                TelemetryError)
from graybox.level_tier import LevelTier, fit_level
from graybox.linear_tier import LinearTier, fit_ar
from graybox.models import WhiteBoxModel, load_model
from graybox.noise_tier import NoiseTier, describe_noise
from graybox.nonlinear_tier import NonlinearTier, fit_networks, lagged
from graybox.parameter_estimation import ParameterEstimate, estimate_parameters
from graybox.residual import residual_frame
from graybox.signature import TIERS, Signature
from graybox.stationarize import Differencing, DifferencingChoice, choose_differencing
from graybox.telemetry import GridPolicy, TelemetryWindow, read_window

__all__ = [
    "GrayBox", "GrayBoxSettings", "FitRequest", "fit_signatures", "fit_baselines",
    "Signature", "Calibration", "Drift", "compute_drift", "decompose", "TIERS",
    "WhiteBoxModel", "load_model", "residual_frame",
    "estimate_parameters", "ParameterEstimate", "diagnose", "Diagnosis", "Hypothesis",
    "read_window", "GridPolicy", "TelemetryWindow",
    # the tiers by hand, on a residual (docs/python-api.md, "Using the tiers by hand")
    "choose_differencing", "Differencing", "DifferencingChoice", "fit_ar", "LinearTier",
    "choose_delay", "choose_dimension", "lagged", "fit_networks", "NonlinearTier",
    "describe_noise", "NoiseTier", "fit_level", "LevelTier",
    "GrayBoxError", "ModelSpecError", "TelemetryError", "InsufficientDataError",
    "StructureMismatchError", "ArtifactError", "InvalidAssetIdError",
]

#: names loaded on first use: the diagnosis imports scipy.stats (0.5 s), which a nightly run's
#: process does not need unless a window alarms
_LAZY = {"Diagnosis": "graybox.diagnosis", "Hypothesis": "graybox.diagnosis",
         "diagnose": "graybox.diagnosis"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'graybox' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if TYPE_CHECKING:  # pragma: no cover
    from graybox.diagnosis import Diagnosis, Hypothesis, diagnose
