"""Errors raised for bad parameters and scenes (kept apart so that every
module can raise them without import cycles)."""
from __future__ import annotations

from typing import Any


class ParameterError(ValueError):
    """A parameter value is missing, unknown, mistyped or physically invalid."""

    def __init__(self, key: str, value: Any, reason: str) -> None:
        self.key = key
        self.value = value
        self.reason = reason
        super().__init__(f"parameter '{key}' = {value!r}: {reason}")
