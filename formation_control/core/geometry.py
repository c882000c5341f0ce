# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""The planar inner product on complex numbers, and the array types of the annotations."""
from __future__ import annotations

from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

RealArray: TypeAlias = NDArray[np.floating[Any]]
"""An array of real numbers (float64 in practice)."""
ComplexArray: TypeAlias = NDArray[np.complexfloating[Any, Any]]
"""An array of complex numbers, planar vectors ``x + i y`` (complex128 in practice)."""
BoolArray: TypeAlias = NDArray[np.bool_]
"""An array of flags."""
IntArray: TypeAlias = NDArray[np.integer[Any]]
"""An array of indices or counts."""


def inner(a: ArrayLike, b: ArrayLike) -> RealArray:
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
