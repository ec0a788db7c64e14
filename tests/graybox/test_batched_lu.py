"""Batched LU solves agree with LAPACK's, pivoting where a leading entry is zero or small,
and a singular matrix raises as numpy.linalg.solve does."""
from __future__ import annotations

import numpy as np
import pytest

from graybox.batched_lu import LARGEST, apply_columns, inverse_columns, lu_factor


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6, LARGEST + 2])
def test_solves_agree_with_lapack(n):
    rng = np.random.default_rng(n)
    a = rng.normal(size=(500, n, n)) + 0.1 * np.eye(n)
    b = rng.normal(size=(500, n))
    lu = lu_factor(a)
    expected = np.linalg.solve(a, b[..., None])[..., 0]
    np.testing.assert_allclose(lu.solve(b), expected, rtol=1e-9, atol=1e-9)
    # the same factors serve a second right-hand side
    c = rng.normal(size=(500, n))
    np.testing.assert_allclose(lu.solve(c), np.linalg.solve(a, c[..., None])[..., 0],
                               rtol=1e-9, atol=1e-9)


def test_a_zero_or_tiny_leading_entry_is_pivoted():
    a = np.array([[[0.0, 1.0, 2.0], [1.0, 0.0, 3.0], [4.0, 5.0, 0.0]],
                  [[1e-20, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
    b = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
    x = lu_factor(a).solve(b)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", a, x), b, rtol=1e-12)
    np.testing.assert_allclose(x[1], [1.0, 1.0, 3.0], rtol=1e-12)


def test_a_singular_matrix_raises():
    a = np.stack([np.eye(3), np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]])])
    with pytest.raises(np.linalg.LinAlgError):
        lu_factor(a)


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_inverse_columns_apply_as_the_inverse(n):
    rng = np.random.default_rng(10 + n)
    a = rng.normal(size=(400, n, n)) + 2.0 * np.eye(n)
    b = rng.normal(size=(400, n))
    inverse = inverse_columns(a)
    assert inverse.shape == (n, n, 400)
    np.testing.assert_allclose(np.moveaxis(inverse, -1, 0), np.linalg.inv(a), rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(apply_columns(inverse, b),
                               np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-9, atol=1e-9)


def test_inverse_columns_of_a_known_matrix():
    a = np.array([[[2.0, 0.0], [1.0, 4.0]]])
    inverse = inverse_columns(a)
    np.testing.assert_allclose(inverse[..., 0], [[0.5, 0.0], [-0.125, 0.25]], rtol=1e-15)
    np.testing.assert_allclose(apply_columns(inverse, np.array([[2.0, 9.0]])), [[1.0, 2.0]],
                               rtol=1e-15)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_inverse_columns_are_the_lu_solves_of_the_unit_vectors_to_the_bit(n):
    # the entry-by-entry inverse does lu_factor's and solve's operations in their order
    rng = np.random.default_rng(20 + n)
    a = rng.normal(size=(3000, n, n)) * rng.choice([1e-3, 1.0, 1e3], size=(3000, 1, 1))
    if n > 1:
        a[::5, 0, 0] = 0.0                                   # pivots
        a[1::5, :, 0] = np.abs(a[1::5, :1, 0])               # ties: the first row wins
        a[2::97, 1, 1] = np.nan
    factors = lu_factor(a)
    expected = np.stack([factors.solve(np.tile(np.eye(n)[j], (len(a), 1))) for j in range(n)],
                        axis=-1)                             # (N, i, j)
    inverse = inverse_columns(a)
    assert np.array_equal(np.moveaxis(inverse, -1, 0), expected, equal_nan=True)
