"""The constant-velocity Kalman filter of :mod:`.tracker`, vectorized over tracks.

A track's state is ``[x, y, vx, vy]`` (m, m, m/s, m/s), world frame; its motion model is the
continuous white-noise acceleration model (Bar-Shalom, Li and Kirubarajan, *Estimation with
Applications to Tracking and Navigation*, 2001, section 6.2.2): each axis moves at constant
velocity, perturbed by white acceleration noise of spectral density ``density`` (m^2/s^3).
A detection measures the position only, with independent noise of variance
``measurement_variance`` (m^2) on each axis.

Every function takes ``n`` tracks at once: ``means`` (n, 4), ``covariances`` (n, 4, 4).
"""

from __future__ import annotations

import numpy as np


def transition(dt: float) -> np.ndarray:
    """The state transition over ``dt`` (s): shape (4, 4)."""
    matrix = np.eye(4)
    matrix[0, 2] = matrix[1, 3] = dt
    return matrix


def process_noise(dt: float, density: float) -> np.ndarray:
    """The process noise covariance over ``dt`` (s) for white acceleration of spectral
    ``density`` (m^2/s^3): shape (4, 4), the discretized continuous model (section 6.2.2)."""
    position, cross, velocity = dt ** 3 / 3.0, dt ** 2 / 2.0, dt
    eye = np.eye(2)
    return density * np.block([[position * eye, cross * eye], [cross * eye, velocity * eye]])


def initial(positions: np.ndarray, position_std: float, velocity_std: float):
    """New tracks at ``positions`` (n, 2) (m), standing still.

    Returns
    -------
    means : ndarray, shape (n, 4)
        ``[x, y, 0, 0]``.
    covariances : ndarray, shape (n, 4, 4)
        Diagonal: ``position_std`` (m) on the position, ``velocity_std`` (m/s) on the velocity.
    """
    count = len(positions)
    means = np.zeros((count, 4))
    means[:, :2] = positions
    diagonal = np.array([position_std, position_std, velocity_std, velocity_std]) ** 2
    covariances = np.broadcast_to(np.diag(diagonal), (count, 4, 4)).copy()
    return means, covariances


def predict(means, covariances, dt: float, density: float):
    """``means`` (n, 4) and ``covariances`` (n, 4, 4) predicted ``dt`` (s) ahead."""
    matrix = transition(dt)
    means = means @ matrix.T
    covariances = matrix @ covariances @ matrix.T + process_noise(dt, density)
    return means, covariances


def innovation_inverse(covariances, measurement_variance: float) -> np.ndarray:
    """The inverse of each track's innovation covariance ``S = P_pos + R``: shape (n, 2, 2)."""
    a = covariances[:, 0, 0] + measurement_variance
    b = covariances[:, 0, 1]
    c = covariances[:, 1, 0]
    d = covariances[:, 1, 1] + measurement_variance
    determinant = a * d - b * c
    inverse = np.empty((len(covariances), 2, 2))
    inverse[:, 0, 0] = d / determinant
    inverse[:, 0, 1] = -b / determinant
    inverse[:, 1, 0] = -c / determinant
    inverse[:, 1, 1] = a / determinant
    return inverse


def mahalanobis(means, s_inverse, positions) -> np.ndarray:
    """Squared Mahalanobis distances from each track's predicted position to each detection.

    Parameters
    ----------
    means : ndarray, shape (n, 4)
    s_inverse : ndarray, shape (n, 2, 2)
        From :func:`innovation_inverse`.
    positions : ndarray, shape (m, 2)
        Detected positions (m).

    Returns
    -------
    ndarray, shape (n, m)
        Dimensionless; chi-square distributed with 2 degrees of freedom for a true match.
    """
    difference = positions[None, :, :] - means[:, None, :2]
    return np.einsum("nmi,nij,nmj->nm", difference, s_inverse, difference)


def correct(means, covariances, s_inverse, positions, measurement_variance: float):
    """The Kalman update of each track with its own detection.

    ``means`` (k, 4), ``covariances`` (k, 4, 4), ``s_inverse`` (k, 2, 2) and ``positions``
    (k, 2) (m) row for row. The covariance is updated in Joseph form, which stays symmetric
    and positive definite in floating point.
    """
    gain = covariances[:, :, :2] @ s_inverse
    residual = positions - means[:, :2]
    means = means + np.einsum("kij,kj->ki", gain, residual)
    reduction = np.broadcast_to(np.eye(4), covariances.shape).copy()
    reduction[:, :, :2] -= gain
    covariances = (reduction @ covariances @ np.swapaxes(reduction, 1, 2)
                   + measurement_variance * gain @ np.swapaxes(gain, 1, 2))
    return means, covariances


def clip_speed(velocities: np.ndarray, max_speed: float) -> np.ndarray:
    """``velocities`` (n, 2) (m/s) scaled down, direction kept, to at most ``max_speed``."""
    speeds = np.hypot(velocities[:, 0], velocities[:, 1])
    scale = np.minimum(1.0, max_speed / np.maximum(speeds, 1e-300))
    return velocities * scale[:, None]
