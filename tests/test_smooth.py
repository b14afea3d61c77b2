"""Smooth stand-ins: exact at temperature 0, converging to it, same in numpy and CasADi."""

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp.core.smooth import (
    CASADI,
    NUMPY,
    relu,
    sabs,
    smax,
    smin,
    smin_positive,
    softmax_objects,
    softmin_objects,
)

X = np.linspace(-3.0, 3.0, 121)
Y = np.linspace(2.0, -1.0, 121)


@pytest.mark.parametrize(
    ("smooth", "exact", "bound"),
    [
        (lambda t: relu(X, t, NUMPY), np.maximum(X, 0.0), lambda t: t * np.log(2.0)),
        (lambda t: smin(X, Y, t, NUMPY), np.minimum(X, Y), lambda t: t * np.log(2.0)),
        (lambda t: smax(X, Y, t, NUMPY), np.maximum(X, Y), lambda t: t * np.log(2.0)),
        (lambda t: sabs(X, t, NUMPY), np.abs(X), lambda t: t),
    ],
    ids=["relu", "smin", "smax", "sabs"],
)
def test_stand_ins_converge_within_their_bound(smooth, exact, bound):
    np.testing.assert_array_equal(smooth(0.0), exact)
    for t in (0.3, 0.03, 0.003):
        assert np.max(np.abs(smooth(t) - exact)) <= bound(t) + 1e-12


def test_smin_positive_is_relative_and_nonnegative():
    a, b = np.abs(X) + 1e-3, np.abs(Y) * 5.0
    exact = np.minimum(a, b)
    for t in (0.1, 0.01):
        value = smin_positive(a, b, t, NUMPY)
        assert np.all(value >= 0.0)
        assert np.all(value <= exact + 1e-15) and np.all(value >= exact * 2.0 ** -t - 1e-15)
    assert smin_positive(np.array(0.0), np.array(0.0), 0.1, NUMPY) == 0.0


def test_softmin_over_objects():
    x = np.array([[[0.3, 1.0, 2.0]]])
    assert softmin_objects(x, 0.0, NUMPY)[0, 0, 0] == 0.3
    for t in (0.1, 0.01):
        assert 0.3 - t * np.log(3) - 1e-12 <= softmin_objects(x, t, NUMPY)[0, 0, 0] <= 0.3
        assert 2.0 <= softmax_objects(x, t, NUMPY)[0, 0, 0] <= 2.0 + t * np.log(3) + 1e-12


def test_casadi_backend_evaluates_the_same_formulas():
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    f = ca.Function("f", [a, b], [relu(a, 0.1, CASADI), smin(a, b, 0.1, CASADI),
                                  smin_positive(ca.fabs(a), ca.fabs(b), 0.05, CASADI),
                                  sabs(a, 0.1, CASADI)])
    for x, y in [(-1.0, 0.5), (0.2, 0.1), (2.0, -3.0)]:
        got = [float(v) for v in f(x, y)]
        want = [relu(x, 0.1, NUMPY), smin(x, y, 0.1, NUMPY),
                smin_positive(abs(x), abs(y), 0.05, NUMPY), sabs(x, 0.1, NUMPY)]
        np.testing.assert_allclose(got, want, atol=1e-12)
    matrix = ca.SX.sym("m", 2, 3)
    g = ca.Function("g", [matrix], [softmin_objects(matrix, 0.05, CASADI),
                                    CASADI.cumprod_steps(matrix)])
    value = np.array([[0.4, 0.1, 0.9], [1.0, 2.0, 0.5]])
    soft, cum = g(value)
    np.testing.assert_allclose(np.array(soft).ravel(),
                               softmin_objects(value[None], 0.05, NUMPY)[0, :, 0], atol=1e-12)
    np.testing.assert_allclose(np.array(cum), np.cumprod(value, axis=0), atol=1e-12)


def test_sigmoid_is_a_smooth_step_without_overflow():
    from dsmpepc_nlp.core.smooth import sigmoid

    x = np.array([-1e6, -5.0, 0.0, 5.0, 1e6])
    with np.errstate(all="raise"):
        value = sigmoid(x, NUMPY)
    np.testing.assert_allclose(value, 1.0 / (1.0 + np.exp(-np.clip(x, -700, 700))), atol=1e-15)
    for t in (0.1, 0.01):     # as a step of x > 0 at temperature t, away from 0
        np.testing.assert_allclose(sigmoid(np.array([-1.0, 1.0]) / t, NUMPY), [0.0, 1.0],
                                   atol=2 * np.exp(-1.0 / t))
    symbol = ca.SX.sym("x")
    f = ca.Function("s", [symbol], [sigmoid(symbol, CASADI)])
    assert float(f(5.0)) == pytest.approx(float(sigmoid(np.array(5.0), NUMPY)), abs=1e-15)
