"""The record of a white box's parameters fitted to telemetry
(:func:`graybox.parameter_estimation.estimate_parameters`): estimates, standard errors and
intervals, kept with a baseline whose white box was tuned to its asset."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import special


@dataclass(frozen=True)
class ParameterEstimate:
    """Parameters of a white box fitted to telemetry, with their standard errors.

    Attributes
    ----------
    names : tuple of str
        The estimated parameters.
    values : tuple of float
        Their estimates.
    standard_errors : tuple of float
        Their standard errors, corrected for the errors' autocorrelation (module docstring).
    covariance : tuple of tuple of float
        The estimates' covariance (same correction), in the order of ``names``.
    initial : tuple of float
        The values the fit started from.
    channels : tuple of str
        The output channels fitted.
    error_std : tuple of float
        Per channel, the RMS k-step prediction error at the estimate (channel units).
    horizon : int
        ``k``, in analysis samples.
    n_obs : int
        Prediction errors used, all channels together.
    effective_samples : float
        Their effective number, all channels together.
    converged : bool
        Whether the least-squares fit met its tolerance (not its evaluation limit).
    positive : tuple of bool, optional
        Per parameter, whether the model declares it positive by nature
        (:func:`graybox.parameter_estimation.positive_parameters`): its interval is then
        normal in the log of the value (never below 0). None in a record stored before it:
        every interval normal in the value.
    """

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"positive"})

    names: tuple[str, ...]
    values: tuple[float, ...]
    standard_errors: tuple[float, ...]
    covariance: tuple[tuple[float, ...], ...]
    initial: tuple[float, ...]
    channels: tuple[str, ...]
    error_std: tuple[float, ...]
    horizon: int
    n_obs: int
    effective_samples: float
    converged: bool
    positive: tuple[bool, ...] | None = None

    def interval(self, level: float = 0.95) -> tuple[tuple[float, float], ...]:
        """Confidence intervals, one ``(low, high)`` per parameter: ``value +- z sd``, or for a
        positive parameter with a positive estimate ``value * exp(+- z sd / value)`` (normal
        in its log, the delta method's ``sd(log value) = sd / value``)."""
        z = float(special.ndtri(0.5 + level / 2))        # scipy.stats.norm.ppf
        positive = self.positive or (False,) * len(self.values)
        return tuple((v * float(np.exp(-z * s / v)), v * float(np.exp(min(z * s / v, 700.0))))
                     if flag and v > 0 else (v - z * s, v + z * s)
                     for v, s, flag in zip(self.values, self.standard_errors, positive))

    def parameters(self) -> dict[str, float]:
        """Name -> estimate, ready as a model's parameter overrides."""
        return dict(zip(self.names, self.values))
