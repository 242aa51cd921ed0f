"""The ``cueing`` parameter group of a machine's params file (design:
/work/shared/design/cueing.md, "Parameters"): :data:`PARAMETER_SPECS`, the one
declaration of its names, types, bounds and meanings (the loaders' validation,
the nodes' descriptors and the docs read it), and :class:`CueingParams`, the
values the washout, the planner and the limiter use.

    params = cueing_params(nested['cueing'])     # ParameterError naming 'cueing.tilt.gain'
    params.translation_gain                      # (3,) array

Every key has a default (the design's set, TU Delft's SIMONA classical washout);
a file may give any part of the group. The limiter's own keys are declared in
:data:`LIMITER_SPECS` (the limiter's method: flight_sim_dynamics.cueing.limiter) and arrive in
:attr:`CueingParams.limiter_settings` by their names without ``cueing.``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..core.parameter_spec import ParamSpec
from .errors import ParameterError, did_you_mean
from .files import flatten
from .validation import check_value

GROUP = 'cueing'
PREFIX = GROUP + '.'
G = 9.80665                 # m/s^2, standard gravity (the design's g)
LIMITERS = ('inverse_dynamics', 'none')
MAX_RATE = 10000.0          # Hz
MAX_GAIN = 10.0
MAX_OMEGA = 1000.0          # rad/s
MAX_ZETA = 100.0


def _spec(name: str, kind: str, default: Any, description: str, unit: str = '', **kw: Any
          ) -> ParamSpec:
    return ParamSpec(PREFIX + name, kind, default, description, unit, required=False, **kw)


def _triple(name: str, default: tuple[float, ...], description: str, unit: str = '',
            minimum: float = 0.0, exclusive: bool = False, maximum: float = MAX_GAIN
            ) -> ParamSpec:
    return _spec(name, 'double_array', list(default), description, unit, minimum=minimum,
                 exclusive_minimum=exclusive, maximum=maximum, length=len(default))


#: The washout's keys (design, "Parameters"); then the limiter's.
WASHOUT_SPECS: tuple[ParamSpec, ...] = (
    _spec('rate', 'double', 1000.0, 'output samples per second of the motion-cueing planner',
          'Hz', minimum=0.0, exclusive_minimum=True, maximum=MAX_RATE),
    _spec('limiter', 'string', 'inverse_dynamics',
          'what keeps every actuator within its limits: inverse_dynamics (the machine\'s '
          'own inverse dynamics and limit rule) or none (the pure washout, whatever it asks '
          'of the machine)', choices=LIMITERS),
    _triple('head', (0.0, 0.0, 0.8), "the occupant's head in the platform frame (cue metrics)",
            'm', minimum=-100.0, maximum=100.0),
    _triple('translation.gain', (0.6, 0.6, 0.5),
            'translational channel gain k_t per axis x, y, z (of the specific force change)'),
    _triple('translation.omega', (0.8, 1.0, 1.0),
            'translational high-pass break frequency omega_t per axis', 'rad/s',
            exclusive=True, maximum=MAX_OMEGA),
    _triple('translation.zeta', (1.0, 1.0, 1.0), 'translational high-pass damping zeta_t per '
            'axis', exclusive=True, maximum=MAX_ZETA),
    _triple('translation.omega_b', (0.0, 0.0, 0.2),
            'translational return term omega_b per axis (s / (s + omega_b)); 0: none',
            'rad/s', maximum=MAX_OMEGA),
    _triple('tilt.gain', (0.6, 0.6),
            'tilt-coordination gain from f_x (pitch) and from f_y (roll)'),
    _triple('tilt.omega', (2.0, 2.0), 'tilt low-pass natural frequency (pitch, roll)', 'rad/s',
            exclusive=True, maximum=MAX_OMEGA),
    _triple('tilt.zeta', (1.0, 1.0), 'tilt low-pass damping (pitch, roll)', exclusive=True,
            maximum=MAX_ZETA),
    _spec('tilt.rate_limit', 'double', math.pi / 60.0,
          'largest tilt rate, applied sample by sample (3 deg/s: about the threshold at '
          'which people notice rotation)', 'rad/s', minimum=0.0, exclusive_minimum=True,
          maximum=100.0),
    _triple('rotation.gain', (0.6, 0.6, 0.6), 'rotational channel gain k_r per axis x, y, z '
            '(of the angular velocity change)'),
    _triple('rotation.omega', (1.0, 0.8, 1.0), 'rotational high-pass break frequency omega_r '
            'per axis', 'rad/s', exclusive=True, maximum=MAX_OMEGA),
    _triple('rotation.zeta', (1.0, 1.0, 1.0), 'rotational high-pass damping zeta_r per axis',
            exclusive=True, maximum=MAX_ZETA),
)

#: Every key of the group, each once: names ``cueing.<...>``, kind, default,
#: meaning, unit, bounds (the one source; config/ validates files with it, the
#: nodes declare their parameters from it).
#: The limiter's keys of the ``cueing`` group (names ``cueing.<...>``, required=False).
LIMITER_SPECS: tuple[ParamSpec, ...] = (
    _spec('margin.stroke', 'double', 0.01,
          "stroke the limiter keeps free at each end of every actuator's travel", 'm',
          minimum=0.0, maximum=1.0),
    _spec('margin.fraction', 'double', 0.05,
          'fraction of the speed, force, condition and joint-angle limits the limiter keeps '
          'free', minimum=0.0, maximum=0.5),
    _spec('braking', 'double_array', [2.0, 2.0],
          'deceleration of the braking the limiter keeps in reserve (translations m/s^2, '
          'rotations rad/s^2): larger brakes later and gives up less cue, with a harder stop',
          'm/s^2, rad/s^2', minimum=0.0, exclusive_minimum=True, maximum=1000.0, length=2),
    _spec('gain.down', 'double', 20.0,
          'rate at which the gain on the washout drops in each cycle that gives up cue '
          '(adaptive gain: fewer braking false cues in a violent stretch)', '1/s',
          minimum=0.0, maximum=1000.0),
    _spec('gain.up', 'double', 1.0,
          'rate at which the gain on the washout returns to 1 in each cycle that gives up '
          'nothing', '1/s', minimum=0.0, exclusive_minimum=True, maximum=1000.0),
    _spec('gain.ahead', 'double', 0.5,
          'rate at which the gain on the washout drops ahead of a motion that would leave '
          "a coordinate's range (the washout's free response, its input held, "
          "``ahead.horizon`` ahead); 0: no look-ahead", '1/s', minimum=0.0, maximum=1000.0),
    _spec('ahead.horizon', 'double', 0.5,
          "how far ahead the washout's free response is looked at", 's',
          minimum=0.0, exclusive_minimum=True, maximum=60.0),
    _spec('ahead.minimum', 'double', 0.7,
          'lowest gain the look-ahead sets (below it, the governor and the adaptive gain '
          "act when the motion comes): a sustained cue's onset is worth more than its "
          'slow tail', minimum=0.0, maximum=1.0),
    _spec('preview.slope', 'double', 0.0,
          'offline runs (the whole log known: ``cue``): how fast the gain on the vehicle\'s '
          'motion goes down before, and back up after, a moment that needs it lower (the '
          'preview, planned from the machine\'s own solves of the washout); 0: no preview '
          '(the look-ahead instead, as when streaming)', '1/s', minimum=0.0, maximum=1000.0),
    _spec('preview.lead', 'double', 1.0,
          'how long before such a moment the preview has lowered the gain (the washout\'s '
          'filters carry the motion before a moment into it)', 's',
          minimum=0.0, maximum=60.0),
    _spec('gain.minimum', 'double', 0.1, 'lowest gain on the washout', minimum=0.0,
          maximum=1.0),
    _spec('recovery.omega', 'double', 1.0,
          'bandwidth of the pull-back that returns the platform to the washout after '
          'limiting (critically damped)', 'rad/s', minimum=0.0, exclusive_minimum=True,
          maximum=100.0),
    _spec('recovery.acceleration', 'double_array', [0.2, 0.2],
          "largest pull-back acceleration on the position while returning to the washout "
          "(translations m/s^2, rotations rad/s^2; the rate's difference is pulled back at "
          'up to the braking deceleration)', 'm/s^2, rad/s^2', minimum=0.0, maximum=1000.0,
          length=2),
)

PARAMETER_SPECS: tuple[ParamSpec, ...] = WASHOUT_SPECS + tuple(LIMITER_SPECS)
SPECS: Mapping[str, ParamSpec] = MappingProxyType({s.name: s for s in PARAMETER_SPECS})
_LIMITER_NAMES = tuple(s.name for s in LIMITER_SPECS)


def _frozen(values: Any) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class CueingParams:
    """The values of the ``cueing`` group (design, "Parameters"); arrays are
    read-only float arrays, per axis x, y, z (tilt: from f_x -> pitch, from
    f_y -> roll). Made by :func:`cueing_params` / :func:`defaults` (the
    defaults are :data:`PARAMETER_SPECS`'s).
    """

    rate: float                   # Hz, output samples
    limiter: str                  # 'inverse_dynamics' or 'none'
    head: np.ndarray              # (3,) m, the head in the platform frame
    translation_gain: np.ndarray  # (3,)
    translation_omega: np.ndarray  # (3,) rad/s
    translation_zeta: np.ndarray  # (3,)
    translation_omega_b: np.ndarray  # (3,) rad/s, 0: no return term
    tilt_gain: np.ndarray         # (2,) from f_x (pitch), from f_y (roll)
    tilt_omega: np.ndarray        # (2,) rad/s
    tilt_zeta: np.ndarray         # (2,)
    tilt_rate_limit: float        # rad/s
    rotation_gain: np.ndarray     # (3,)
    rotation_omega: np.ndarray    # (3,) rad/s
    rotation_zeta: np.ndarray     # (3,)
    #: the limiter's keys (:data:`LIMITER_SPECS`) by their names
    #: without ``cueing.`` (``limiter_margin``), every one given or defaulted
    limiter_settings: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def period(self) -> float:
        """s, one output sample (1 / rate)."""
        return 1.0 / self.rate

    def replace(self, **changes: Any) -> 'CueingParams':
        """A copy with ``changes`` (attribute names), arrays frozen (tests, tools)."""
        values = {name: getattr(self, name) for name in self.__dataclass_fields__}
        values.update(changes)
        return CueingParams(**{k: (_frozen(v) if isinstance(getattr(self, k), np.ndarray) else v)
                               for k, v in values.items()})


def _attribute(name: str) -> str:
    """``cueing.translation.omega_b`` -> ``translation_omega_b``."""
    return name[len(PREFIX):].replace('.', '_')


def cueing_params_flat(flat: Mapping[str, Any], source: str = '') -> CueingParams:
    """:class:`CueingParams` of dotted full names (``cueing.tilt.gain``: as a
    node's parameters or a flattened file give them); absent keys take their
    defaults. ParameterError naming the key for an unknown name (with "did you
    mean"), a wrong type or a value out of bounds; ``source`` (a file) is named
    in the message.
    """
    where = f' in {source}' if source else ''
    values: dict[str, Any] = {_attribute(s.name): s.default for s in WASHOUT_SPECS}
    settings: dict[str, Any] = {}
    for key, value in flat.items():
        spec = SPECS.get(key)
        if spec is None:
            raise ParameterError(key, value, f'unknown parameter of the {GROUP} group{where}'
                                 + did_you_mean(key, SPECS))
        try:
            checked = check_value(spec, value)
        except ParameterError as exc:
            raise ParameterError(exc.key, exc.value, exc.reason + where) from None
        if key in _LIMITER_NAMES:
            settings[key[len(PREFIX):]] = checked
        else:
            values[_attribute(key)] = checked
    for spec in LIMITER_SPECS:
        settings.setdefault(spec.name[len(PREFIX):], spec.default)
    arrays = {k: _frozen(v) for k, v in values.items() if isinstance(v, list)}
    values.update(arrays)
    return CueingParams(**values, limiter_settings=MappingProxyType(settings))


def cueing_params(values: Mapping[str, Any] | None, source: str = '') -> CueingParams:
    """:class:`CueingParams` of a params file's nested ``cueing`` group (None or
    empty: every default). ParameterError naming the dotted key
    (``cueing.translation.gain``) for anything unknown, mistyped or out of bounds.
    """
    if values is None:
        return cueing_params_flat({}, source)
    if not isinstance(values, Mapping):
        raise ParameterError(GROUP, values, 'expected a group of parameters (a mapping)'
                             + (f' in {source}' if source else ''))
    return cueing_params_flat(flatten(values, PREFIX) if values else {}, source)


def defaults() -> CueingParams:
    """Every key at its default (the design's set)."""
    return cueing_params_flat({})


def split_cueing(flat: Mapping[str, Any], source: str = '') -> tuple[dict[str, Any],
                                                                      CueingParams]:
    """A params file's parameters (dotted names) without its ``cueing`` group,
    and the group's values, checked (:func:`cueing_params_flat`: ParameterError
    naming the key): how the loaders of models and nodes read a file that has one.
    """
    group = {k: v for k, v in flat.items() if k.startswith(PREFIX) or k == GROUP}
    if GROUP in group:           # 'cueing: 3' (not a group)
        raise ParameterError(GROUP, group[GROUP], 'expected a group of parameters (a mapping)'
                             + (f' in {source}' if source else ''))
    rest = {k: v for k, v in flat.items() if k not in group}
    return rest, cueing_params_flat(group, source)
