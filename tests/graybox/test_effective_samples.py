import numpy as np
import pytest

from graybox.effective_samples import integrated_time


def test_integrated_time_of_an_ar1_autocorrelation_is_its_known_value():
    # rho_k = phi^k: 1 + 2 sum_k>=1 phi^k = (1 + phi) / (1 - phi), 9 at phi = 0.8
    rho = 0.8 ** np.arange(400)
    assert integrated_time(rho) == pytest.approx(9.0, rel=1e-12)
    assert integrated_time(rho[:399]) == pytest.approx(9.0, rel=1e-12)        # an odd length


def test_integrated_time_stops_at_the_first_pair_that_is_not_positive():
    # pairs (1 + 0.5), (-0.6 - 0.5): only the first counts, -1 + 2 x 1.5 = 2
    assert integrated_time(np.array([1.0, 0.5, -0.6, -0.5, 0.9, 0.9])) == pytest.approx(2.0)
    # a negatively correlated series counts as independent: never below 1
    assert integrated_time(np.array([1.0, -0.9, 0.0, 0.0])) == 1.0
