"""Array backends (numpy, CasADi) and the smooth stand-ins for min, max, |.| and clipping.

Every formula of the control law and the cost is written once against a backend ``ops``:
``NUMPY`` evaluates it on batched arrays, ``CASADI`` builds the symbolic graph of the NLP. A
stand-in takes a temperature in the unit of its argument; a temperature of 0 gives the exact
form, and the smooth form converges to it as the temperature goes to 0 (held by tests).

Array layout shared by both backends: numpy arrays are batch-first ``(n, steps, objects)``; the
CasADi graph holds one trajectory, so the same quantity is a ``(steps, objects)`` matrix.
Reductions keep their axis so that one formula serves both.
"""

from __future__ import annotations

import casadi as ca
import numpy as np


class NumpyOps:
    """Elementwise maths and axis reductions on batched numpy arrays."""

    name = "numpy"
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    atan = staticmethod(np.arctan)
    atan2 = staticmethod(np.arctan2)
    sqrt = staticmethod(np.sqrt)
    exp = staticmethod(np.exp)
    tanh = staticmethod(np.tanh)
    log1p = staticmethod(np.log1p)
    fabs = staticmethod(np.abs)
    fmin = staticmethod(np.minimum)
    fmax = staticmethod(np.maximum)

    @staticmethod
    def where(condition, if_true, if_false):
        return np.where(condition, if_true, if_false)

    @staticmethod
    def prod_objects(x):
        """Product over the last (object) axis, kept."""
        return np.prod(x, axis=-1, keepdims=True)

    @staticmethod
    def min_objects(x):
        return np.min(x, axis=-1, keepdims=True)

    @staticmethod
    def max_objects(x):
        return np.max(x, axis=-1, keepdims=True)

    @staticmethod
    def logsumexp_objects(x):
        top = np.max(x, axis=-1, keepdims=True)
        return top + np.log(np.sum(np.exp(x - top), axis=-1, keepdims=True))

    @staticmethod
    def cumprod_steps(x):
        """Cumulative product along the step axis (second to last)."""
        return np.cumprod(x, axis=-2)

    @staticmethod
    def sum_steps(x):
        return np.sum(x, axis=-2, keepdims=True)

    @staticmethod
    def steps(x, start=None, stop=None):
        """Slice of the step axis."""
        return x[..., start:stop, :]


class CasadiOps:
    """The same interface on CasADi SX/MX matrices of shape ``(steps, objects)``."""

    name = "casadi"
    sin = staticmethod(ca.sin)
    cos = staticmethod(ca.cos)
    atan = staticmethod(ca.atan)
    atan2 = staticmethod(ca.atan2)
    sqrt = staticmethod(ca.sqrt)
    exp = staticmethod(ca.exp)
    tanh = staticmethod(ca.tanh)
    log1p = staticmethod(ca.log1p)
    fabs = staticmethod(ca.fabs)
    fmin = staticmethod(ca.fmin)
    fmax = staticmethod(ca.fmax)

    @staticmethod
    def where(condition, if_true, if_false):
        return ca.if_else(condition, if_true, if_false)

    @staticmethod
    def _fold_columns(x, combine):
        result = x[:, 0]
        for column in range(1, x.shape[1]):
            result = combine(result, x[:, column])
        return result

    @classmethod
    def prod_objects(cls, x):
        return cls._fold_columns(x, lambda a, b: a * b)

    @classmethod
    def min_objects(cls, x):
        return cls._fold_columns(x, ca.fmin)

    @classmethod
    def max_objects(cls, x):
        return cls._fold_columns(x, ca.fmax)

    @classmethod
    def logsumexp_objects(cls, x):
        top = cls.max_objects(x)
        shifted = ca.exp(x - ca.repmat(top, 1, x.shape[1]))
        return top + ca.log(ca.sum2(shifted))

    @staticmethod
    def cumprod_steps(x):
        rows = [x[0, :]]
        for row in range(1, x.shape[0]):
            rows.append(rows[-1] * x[row, :])
        return ca.vertcat(*rows)

    @staticmethod
    def sum_steps(x):
        return ca.sum1(x)

    @staticmethod
    def steps(x, start=None, stop=None):
        return x[slice(start, stop), :]


NUMPY = NumpyOps()
CASADI = CasadiOps()


# --- smooth stand-ins: exact at temperature 0 ----------------------------------------------


def is_exact(temperature) -> bool:
    """True for a plain zero temperature; an array or symbolic temperature is never exact."""
    return isinstance(temperature, (int, float)) and temperature == 0


def relu(x, temperature, ops):
    """``max(x, 0)``; smooth: ``t log(1 + exp(x / t))`` (softplus), above it by at most t log 2."""
    if is_exact(temperature):
        return ops.fmax(x, 0.0)
    # max(x, 0) + t log(1 + exp(-|x|/t)) is softplus written without overflow.
    return ops.fmax(x, 0.0) + temperature * ops.log1p(ops.exp(-ops.fabs(x) / temperature))


def smin(a, b, temperature, ops):
    """``min(a, b)``; smooth: ``a - softplus_t(a - b)``, below the exact min by at most t*log 2."""
    if is_exact(temperature):
        return ops.fmin(a, b)
    return a - relu(a - b, temperature, ops)


def smax(a, b, temperature, ops):
    """``max(a, b)``; smooth: ``a + softplus_t(b - a)``, above the exact max by at most t*log 2."""
    if is_exact(temperature):
        return ops.fmax(a, b)
    return a + relu(b - a, temperature, ops)


def smin_positive(a, b, temperature, ops):
    """``min(a, b)`` of non-negative quantities; smooth: ``(a^-p + b^-p)^(-1/p)``, ``p = 1/t``.

    The temperature is relative (dimensionless): the smooth value lies within a factor
    ``2^-t`` below the exact minimum, so it stays >= 0 and is exact at 0, whatever the scale.
    """
    if is_exact(temperature):
        return ops.fmin(a, b)
    low, high = ops.fmin(a, b), ops.fmax(a, b)
    # Written through min and max for stability; the function itself is symmetric and smooth.
    # The floor (1e-12 in the unit of a and b) keeps second derivatives finite at a = b = 0,
    # where 1/1e-300 overflowed and made the Hessian NaN (0 * inf) at v_max = 0.
    ratio = low / ops.fmax(high, 1e-12)
    return low * (1.0 + ratio ** (1.0 / temperature)) ** (-temperature)


def sigmoid(x, ops):
    """The logistic function ``1 / (1 + exp(-x))``, written with tanh so it never overflows.

    ``sigmoid(x / t)`` is the smooth stand-in of the step ``x > 0`` at temperature ``t``.
    """
    return 0.5 + 0.5 * ops.tanh(0.5 * x)


def sabs(x, temperature, ops):
    """``|x|``; smooth: ``sqrt(x^2 + t^2)``, above |x| by at most t."""
    if is_exact(temperature):
        return ops.fabs(x)
    return ops.sqrt(x * x + temperature * temperature)


def softmin_objects(x, temperature, ops):
    """Smallest value along the object axis; smooth: ``-t * logsumexp(-x / t)``.

    The soft-min lies below the exact minimum by at most ``t * log(count)``.
    """
    if is_exact(temperature):
        return ops.min_objects(x)
    return -temperature * ops.logsumexp_objects(-x / temperature)


def softmax_objects(x, temperature, ops):
    """Largest value along the object axis; smooth: ``t * logsumexp(x / t)``."""
    if is_exact(temperature):
        return ops.max_objects(x)
    return temperature * ops.logsumexp_objects(x / temperature)
