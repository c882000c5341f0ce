"""Small planar helpers: the complex inner product and angle wrapping."""
import numpy as np


def inner(a, b):
    """Return ``<a, b> = Re(conj(a) b)``, the inner product of footnote 1 (Ch. 1)."""
    return (np.conj(a) * b).real


def wrap(angle):
    """Wrap an angle (rad) to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi
