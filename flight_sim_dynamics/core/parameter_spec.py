"""The declaration of one parameter (:class:`ParamSpec`): what the node's
descriptors, the validation of values and the docs' tables read. The node's
are config/schema.py's; each machine declares its own
(:attr:`flight_sim_dynamics.core.machine.Machine.parameter_specs`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

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
