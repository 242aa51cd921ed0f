"""The error of a bad parameter, file or scene, and "did you mean"."""
from __future__ import annotations

import difflib
import re
from typing import Any, Iterable


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


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``; did you mean 'x'?`` for the closest known name (difflib), else ''."""
    close = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ''
