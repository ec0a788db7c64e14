"""The record of a white box's parameters fitted to telemetry
(:func:`graybox.parameter_estimation.estimate_parameters`): estimates, standard errors and
intervals, kept with a baseline whose white box was tuned to its asset."""
from __future__ import annotations

from dataclasses import dataclass

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
    """

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

    def interval(self, level: float = 0.95) -> tuple[tuple[float, float], ...]:
        """Normal confidence intervals ``value +- z sd``, one ``(low, high)`` per parameter."""
        z = float(special.ndtri(0.5 + level / 2))        # scipy.stats.norm.ppf
        return tuple((v - z * s, v + z * s) for v, s in zip(self.values, self.standard_errors))

    def parameters(self) -> dict[str, float]:
        """Name -> estimate, ready as a model's parameter overrides."""
        return dict(zip(self.names, self.values))
