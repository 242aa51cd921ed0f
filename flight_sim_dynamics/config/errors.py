"""The error of a bad parameter, file or scene, and "did you mean"."""
from __future__ import annotations

import difflib
from typing import Any, Iterable


class ParameterError(ValueError):
    """A parameter value is missing, unknown, mistyped or physically invalid."""

    def __init__(self, key: str, value: Any, reason: str) -> None:
        self.key, self.value, self.reason = key, value, reason
        text = repr(value)
        if len(text) > 200:
            text = text[:200] + f'... ({len(text)} characters)'
        super().__init__(f"parameter '{key}' = {text}: {reason}")


class IgnoredParameterWarning(UserWarning):
    """Values of a parameter file the model does not use: parameters of an
    effect its scene leaves out (e.g. ``payload.mass`` with the ``full`` scene).
    """


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``; did you mean 'x'?`` for the closest known name (difflib), else ''."""
    close = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ''
