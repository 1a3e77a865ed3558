"""The names the harness gives its numbers' types, so a signature says what it holds.

`Vector` and `Matrix` are float arrays (one state's q, v, tau; a mass matrix); `Floats` is anything numpy
reads as floats (an array, a list, a number). `Json` is a value JSON can hold, `JsonObject` one object of
results.json as the harness writes it: readers narrow what they take out of it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

Vector: TypeAlias = npt.NDArray[np.float64]  # shape (n,)
Matrix: TypeAlias = npt.NDArray[np.float64]  # shape (n, n) or (states, n)
Floats: TypeAlias = npt.NDArray[np.float64] | Sequence[float] | float

Json: TypeAlias = str | int | float | bool | None | list["Json"] | dict[str, "Json"]
JsonObject: TypeAlias = dict[str, Json]

__all__ = ["Floats", "Json", "JsonObject", "Matrix", "Vector"]
