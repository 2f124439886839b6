"""Array copies for compiled code, element by element.

numba compiles an array slice assignment (``target[a:b] = source``) with a shape check whose
error message formats both shapes: string code that takes seconds to compile in every process
that meets it first, before numba's cache can help. The kernels a run compiles before its
first step copy arrays with :func:`copy_rows` instead.
"""

from __future__ import annotations

from numba import njit
from numpy.typing import NDArray


@njit(cache=True, inline="always")
def copy_rows(source: NDArray, target: NDArray, first: int) -> None:
    """Copy the 2-D ``source`` into rows ``first`` to ``first + len(source)`` of ``target``.

    :param source: (M, K) array
    :param target: (at least first + M, at least K) array of a dtype ``source`` casts to
    """
    for row in range(source.shape[0]):
        for column in range(source.shape[1]):
            target[first + row, column] = source[row, column]
