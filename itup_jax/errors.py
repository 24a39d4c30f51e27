"""The one exception type for bad user input.

`InputError` subclasses `ValueError`, so callers that already catch `ValueError` keep working. Every
message names the offending input (file, field or argument) and says what is wrong with it.
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: the message names the input and the problem."""
