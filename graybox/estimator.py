"""The gray box for one asset: the estimator a user meets.

:class:`GrayBox` follows scikit-learn's estimator rules (arguments stored in ``__init__``,
learning in :meth:`GrayBox.fit`, which returns self). It is built on the fleet forms:
:func:`graybox.signature_fit.fit_signatures` (batched fitting of many assets) and
:func:`graybox.calibration.fit_baselines` (baselines with calibrated epsilons), re-exported
here with :class:`~graybox.settings.GrayBoxSettings` and :class:`~graybox.signature_fit.FitRequest`.
"""
from __future__ import annotations

from dataclasses import replace

from typing import Sequence

import pandas as pd

from graybox.calibration import DEFAULT_FALSE_ALARM_RATE, fit_baselines
from graybox.drift import Drift, compute_drift
from graybox.exceptions import GrayBoxError
from graybox.signature_fit import FitRequest, fit_signatures
from graybox.models.base import WhiteBoxModel
from graybox.settings import GrayBoxSettings
from graybox.signature import Signature
from graybox.tiers import TIER_KINDS, Tier

__all__ = ["GrayBox", "GrayBoxSettings", "FitRequest", "fit_signatures", "fit_baselines"]


class GrayBox:
    """The gray-box estimator for one asset.

    Without ``baseline`` it learns a structure and healthy parameters from K >= 3 healthy
    windows and calibrates epsilon (``signature_``, ``calibration_``). With ``baseline`` it
    fits a candidate with the baseline's frozen structure, starting from the baseline's
    network weights, so that zeta measures drift rather than the optimizer's luck.

    Parameters
    ----------
    model : WhiteBoxModel
        The physics model used as residual filter.
    baseline : Signature, optional
        Fit a candidate against this baseline.
    settings : GrayBoxSettings, optional
        Defaults to ``GrayBoxSettings()`` for a baseline and to the baseline's own settings
        for a candidate.
    false_alarm_rate : float, default 0.01
        Target false alarms per asset and window, sets epsilon.
    calibrate : bool, default True
        Calibrate epsilon when fitting a baseline (needs at least 3 windows).
    random_state : int, default 0
        Seeds the random initial network weights of a baseline.
    kinds : sequence of Tier, optional
        The tiers to fit, calibrate and compare (default
        :data:`graybox.tiers.TIER_KINDS`); an added tier is one more
        :class:`graybox.tiers.Tier` here.

    Attributes
    ----------
    signature_ : Signature
    calibration_ : Calibration or None

    Examples
    --------
    >>> baseline = GrayBox(model).fit(healthy_days)                       # doctest: +SKIP
    >>> candidate = GrayBox(model, baseline=baseline.signature_).fit(night)   # doctest: +SKIP
    >>> drift = compute_drift(candidate.signature_, baseline.signature_,
    ...                       baseline.calibration_)                        # doctest: +SKIP
    """

    def __init__(self, model: WhiteBoxModel, baseline: Signature | None = None,
                 settings: GrayBoxSettings | None = None,
                 false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE,
                 calibrate: bool = True, random_state: int = 0,
                 kinds: Sequence[Tier] | None = None):
        self.model = model
        self.baseline = baseline
        self.settings = settings
        self.false_alarm_rate = false_alarm_rate
        self.calibrate = calibrate
        self.random_state = random_state
        self.kinds = kinds

    def fit(self, windows) -> "GrayBox":
        """Fit on one window or a sequence of windows (TelemetryWindow or uniform-grid DataFrame).

        Returns
        -------
        self
        """
        windows = [windows] if isinstance(windows, pd.DataFrame) or hasattr(windows, "frame") else list(windows)
        settings = self.settings
        if self.baseline is not None:
            if settings is not None and settings.min_samples == "auto":
                # "auto" was resolved by the baseline's own windows
                settings = replace(settings, min_samples=self.baseline.settings.min_samples)
            if settings is not None and settings != self.baseline.settings:
                raise GrayBoxError("a candidate must be fitted with its baseline's settings "
                                   "(leave settings out, or pass baseline.settings)")
            settings = self.baseline.settings
        settings = settings or GrayBoxSettings()
        request = FitRequest(self.model, windows, self.baseline, seed=self.random_state)
        kinds = self._kinds()
        self.calibration_ = None
        if self.baseline is None and self.calibrate:
            result = fit_baselines([request], settings, self.false_alarm_rate, kinds=kinds)[0]
            if isinstance(result, GrayBoxError):
                raise result
            self.signature_, self.calibration_ = result
        else:
            result = fit_signatures([request], settings, kinds=kinds)[0]
            if isinstance(result, GrayBoxError):
                raise result
            self.signature_ = result
        return self

    def drift(self, windows) -> Drift:
        """Fit a candidate on ``windows`` against this fitted baseline and return its drift."""
        candidate = GrayBox(self.model, baseline=self.signature_, settings=self.settings,
                            kinds=self.kinds).fit(windows)
        return compute_drift(candidate.signature_, self.signature_, self.calibration_,
                             kinds=self._kinds())

    def _kinds(self) -> tuple[Tier, ...]:
        return TIER_KINDS if self.kinds is None else tuple(self.kinds)
