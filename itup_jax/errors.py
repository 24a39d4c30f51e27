"""The one exception type for bad user input.

`InputError` subclasses `ValueError`, so callers that already catch `ValueError` keep working. Every
message names the offending input (file, field or argument) and says what is wrong with it.
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: the message names the input and the problem."""


def is_integer(v) -> bool:
    """Whether `v` is a Python or NumPy integer, booleans excluded (True is not a count)."""
    import numpy as np

    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def check_seed(seed, where: str) -> int:
    """`seed` as an int if it is an integer >= 0 (what NumPy's generators take), else InputError naming
    `where`."""
    if not is_integer(seed) or seed < 0:
        raise InputError(f"{where}: seed must be an integer >= 0, got {seed!r}")
    return int(seed)
