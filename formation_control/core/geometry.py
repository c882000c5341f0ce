"""The planar inner product on complex numbers."""
import numpy as np


def inner(a, b):
    """
    Return the inner product of planar vectors written as complex numbers.

    Parameters
    ----------
    a, b : complex or array_like of complex
        Vectors ``x + i y``; broadcast together.

    Returns
    -------
    float or ndarray
        ``<a, b> = Re(conj(a) b) = a_x b_x + a_y b_y``, footnote 1 (Ch. 1).

    """
    return (np.conj(a) * b).real
