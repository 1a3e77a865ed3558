"""What a module's function returns, made a real float array or refused by name.

`np.asarray(x, dtype=float)` accepts too much: it drops an imaginary part with a ComplexWarning,
turns a numeric string into a number and an object array of anything float-like into floats, so a
mass matrix written `m + 5j` passed every row. Every conversion of a module's output goes through
`real_array`, which takes integers, booleans and floats (NaN and inf included: they are findings
judged downstream, never warnings) and refuses complex values, strings, objects, ragged nested
lists and a shape that does not broadcast to the expected one, in one line naming the function.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import HarnessError

_KINDS = {
    "c": "complex values",
    "O": "Python objects (dtype object)",
    "U": "strings",
    "S": "bytes",
    "M": "datetimes",
    "m": "timedeltas",
    "V": "structured records",
}


def _expected(shape: tuple[int, ...] | None) -> str:
    return "real numbers" if shape is None else f"real numbers of shape {shape}"


def real_array(name: str, value: object, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """`value` as a float array (broadcast to `shape` where given), or a HarnessError
    "mass_matrix() returned complex values; expected real numbers of shape (100, 2, 2)".

    Args:
        name: what returned it, as the person wrote it ("mass_matrix()", "body_positions()['link']").
        value: the function's return value.
        shape: the shape the caller needs; a value that broadcasts to it is broadcast (a copy).
    """
    try:
        arr = np.asarray(value)
    except ValueError:  # numpy 2: "setting an array element with a sequence ... inhomogeneous shape"
        raise HarnessError(f"{name} returned a ragged nested list; expected {_expected(shape)}") from None
    what = _KINDS.get(arr.dtype.kind)
    if what is not None:
        raise HarnessError(f"{name} returned {what}; expected {_expected(shape)}")
    out = arr.astype(float, copy=False)
    if shape is None or out.shape == shape:
        return out
    try:
        return np.broadcast_to(out, shape).copy()
    except ValueError:
        raise HarnessError(f"{name} returned shape {arr.shape}; expected {_expected(shape)}") from None
