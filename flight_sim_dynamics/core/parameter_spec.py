"""The declaration of one parameter (:class:`ParamSpec`): what the node's
descriptors, the validation of values and the docs' tables read. The node's
are config/schema.py's; each machine declares its own
(:attr:`flight_sim_dynamics.core.machine.Machine.parameter_specs`). The one
check of a value against its declaration (:func:`check_value`,
:func:`checked_values`) is every loader's and every machine builder's, so that
each bound is written once: in its spec.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import numpy as np

# Physical bounds every machine's parameters share: no mechanism has a body of
# more than 100 t or lengths of more than 100 m, and far beyond them the
# solver's products overflow (a mass of 1e308 kg answers nothing but
# invalid_input). Each spec declares its bound; the loaders check it.
MAX_MASS = 1.0e5            # kg, a body's mass
MAX_COM = 100.0             # m, |component| of a centre of mass
MAX_INERTIA = 1.0e6         # kg m^2, |entry| of an inertia tensor
MAX_LENGTH = 100.0          # m, a geometry length, |component| of a joint position
MAX_GRAVITY = 100.0         # m/s^2, ten times the Earth's
MAX_SPEED = 1.0e3           # m/s, an actuator speed limit
MAX_FORCE = 1.0e9           # N, an actuator force limit
MAX_FRICTION = 1.0e6        # N s/m or N, a friction coefficient
MAX_CONDITION = 1.0e16      # a condition-number threshold (1 / machine epsilon)


class ModelValueError(ValueError):
    """A machine's model builder refuses a parameter: ``key`` is its dotted
    name (``bodies.rod.mass``; an element's index dropped), the message says why.
    """

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class ParamSpec:
    """One declared parameter. ``kind``: ``double``, ``double_array``, ``integer``,
    ``string`` or ``bool``; ``minimum``/``maximum`` bound a number or each element
    (inclusive unless ``exclusive_minimum``); ``length``: an array's size.
    """

    name: str
    kind: str
    default: Any
    description: str
    unit: str = ''
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    length: int | None = None
    choices: tuple[str, ...] | None = None
    required: bool = True     # a complete model file must give it (model parameters only)
    max_length: int | None = None   # most characters of a string

    @property
    def full_description(self) -> str:
        return f'{self.description} [{self.unit}]' if self.unit else self.description

    @property
    def range_text(self) -> str:
        """The valid values in words: ``(0, 100]``, ``3 numbers in [-100, 100]``,
        ``at most 256 characters``, ``backward | backward2`` (for the docs).
        """
        if self.choices:
            return ' | '.join(self.choices)
        if self.kind == 'bool':
            return 'true | false'
        if self.max_length is not None:
            return f'at most {self.max_length} characters'
        bounds = ''
        if self.minimum is not None or self.maximum is not None:
            low = '' if self.minimum is None else f'{self.minimum:g}'
            high = '' if self.maximum is None else f'{self.maximum:g}'
            bounds = f"{'(' if self.exclusive_minimum else '['}{low}, {high}]"
        if self.length or self.kind == 'double_array':
            return f'{self.length or ""} numbers'.lstrip() + (f' in {bounds}' if bounds else '')
        return bounds


def _number(spec: ParamSpec, item: Any, where: str = '') -> float:
    """One number of a value (``item``), as a finite float within the spec's bounds."""
    key = spec.name
    if isinstance(item, (bool, np.bool_)) or not isinstance(item, (int, float, np.integer,
                                                                   np.floating)):
        raise ModelValueError(key, f'expected a number{where}, got {type(item).__name__}')
    try:
        v = float(item)
    except OverflowError:       # an int beyond the float range (10**400)
        raise ModelValueError(key, f'must be finite{where}') from None
    if not math.isfinite(v):
        raise ModelValueError(key, f'must be finite{where}')
    unit = f' {spec.unit}' if spec.unit else ''
    if spec.minimum is not None:
        if spec.exclusive_minimum and v <= spec.minimum:
            raise ModelValueError(key, f'must be > {spec.minimum:g}{unit}{where}')
        if not spec.exclusive_minimum and v < spec.minimum:
            raise ModelValueError(key, f'must be >= {spec.minimum:g}{unit}{where}')
    if spec.maximum is not None and v > spec.maximum:
        raise ModelValueError(key, f'must be <= {spec.maximum:g}{unit}{where}')
    return v


def check_value(spec: ParamSpec, value: Any) -> Any:
    """Type- and range-check one value against its spec; returns it in its
    canonical Python type (float, list of floats, int, str, bool). The one
    conversion: an integer for a floating-point parameter (``mass: 2``, exact).
    :class:`ModelValueError` naming the key, the message saying why.
    """
    key = spec.name
    if spec.kind == 'double':
        return _number(spec, value)
    if spec.kind == 'double_array':
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            raise ModelValueError(key, f'expected a list of {spec.length} numbers')
        if spec.length is not None and len(value) != spec.length:
            raise ModelValueError(key, f'expected {spec.length} numbers, got {len(value)}')
        return [_number(spec, v, f' (element {i})') for i, v in enumerate(value)]
    if spec.kind == 'integer':
        if isinstance(value, bool) or not isinstance(value, int):
            raise ModelValueError(key, f'expected an integer, got {type(value).__name__}')
        if spec.minimum is not None and value < spec.minimum:
            raise ModelValueError(key, f'must be >= {spec.minimum:g}')
        if spec.maximum is not None and value > spec.maximum:
            raise ModelValueError(key, f'must be <= {spec.maximum:g}')
        return value
    if spec.kind == 'string':
        if not isinstance(value, str):
            raise ModelValueError(key, f'expected a string, got {type(value).__name__}')
        if spec.max_length is not None and len(value) > spec.max_length:
            raise ModelValueError(key, f'longer than {spec.max_length} characters '
                                       f'({len(value)})')
        if spec.choices is not None and value not in spec.choices:
            raise ModelValueError(key, f"must be one of {', '.join(spec.choices)}"
                                  + did_you_mean(value, spec.choices))
        return value
    if spec.kind == 'bool':
        if not isinstance(value, bool):
            raise ModelValueError(key, f'expected true or false, got {type(value).__name__}')
        return value
    raise AssertionError(f'unknown parameter kind {spec.kind}')  # pragma: no cover


def checked_values(specs: Iterable[ParamSpec], values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` (flat dotted names) with each one ``specs`` declare checked
    (:func:`check_value`) and canonical, the others as given; the first refused
    is a :class:`ModelValueError` naming its key.
    """
    out = dict(values)
    for spec in specs:
        if spec.name in values:
            out[spec.name] = check_value(spec, values[spec.name])
    return out


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``; did you mean 'x'?`` for the closest known name (difflib), else ''."""
    close = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ''
