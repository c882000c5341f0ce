"""The planar inner product on complex numbers."""
import numpy as np


def inner(a, b):
    """Return ``<a, b> = Re(conj(a) b)``, the inner product of footnote 1 (Ch. 1)."""
    return (np.conj(a) * b).real

