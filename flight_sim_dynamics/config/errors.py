"""The error of a bad parameter, file or scene, and "did you mean"."""
from __future__ import annotations

import re
from typing import Any

from ..core.parameter_spec import did_you_mean

__all__ = ['IgnoredParameterWarning', 'ParameterError', 'did_you_mean', 'shorten']


#: Longest word of a message shown whole (a value echoed: a name, a path).
LONGEST_WORD = 256


def shorten(text: str, longest: int = LONGEST_WORD) -> str:
    """``text`` with each word (a run without white space) longer than
    ``longest`` characters cut to that length, ``<its start>... (N characters)``,
    so that a message echoing a huge value (a 200 KB machine name) stays
    readable; a shortened text is its own shortening.
    """
    return re.sub(r'\S{%d,}' % (longest + 1),
                  lambda m: f'{m[0][:longest - 3]}... ({len(m[0])} characters)', text)


class ParameterError(ValueError):
    """A parameter value is missing, unknown, mistyped or physically invalid."""

    def __init__(self, key: str, value: Any, reason: str) -> None:
        self.key, self.value, self.reason = key, value, reason
        text = repr(value)
        if len(text) > 200:
            text = text[:200] + f'... ({len(text)} characters)'
        super().__init__(shorten(f"parameter '{key}' = {text}: {reason}"))


class IgnoredParameterWarning(UserWarning):
    """Values of a parameter file the model does not use: parameters of an
    effect its scene leaves out (e.g. ``payload.mass`` with the ``full`` scene).
    """
