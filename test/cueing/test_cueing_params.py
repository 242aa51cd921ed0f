"""The cueing parameter group (flight_sim_dynamics/config/cueing.py): the
design's defaults, any part of the group given, errors naming the dotted key."""
from __future__ import annotations

import math

import numpy as np
import pytest

from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.validation import check_value
from flight_sim_dynamics.config.cueing import (PARAMETER_SPECS, CueingParams, cueing_params,
                                               cueing_params_flat, defaults)

#: The design's group (/work/shared/design/cueing.md, "Parameters").
DESIGN = {
    'rate': 1000.0, 'limiter': 'inverse_dynamics', 'head': [0.0, 0.0, 0.8],
    'translation': {'gain': [0.6, 0.6, 0.5], 'omega': [0.8, 1.0, 1.0],
                    'zeta': [1.0, 1.0, 1.0], 'omega_b': [0.0, 0.0, 0.2]},
    'tilt': {'gain': [0.6, 0.6], 'omega': [2.0, 2.0], 'zeta': [1.0, 1.0],
             'rate_limit': 0.05235987755982988},
    'rotation': {'gain': [0.6, 0.6, 0.6], 'omega': [1.0, 0.8, 1.0], 'zeta': [1.0, 1.0, 1.0]},
}


def same(a: CueingParams, b: CueingParams) -> bool:
    return all(np.array_equal(getattr(a, n), getattr(b, n)) if isinstance(getattr(a, n),
                                                                          np.ndarray)
               else getattr(a, n) == getattr(b, n) for n in a.__dataclass_fields__)


def test_the_defaults_are_the_design_set():
    assert same(defaults(), cueing_params(DESIGN))
    assert same(defaults(), cueing_params({})) and same(defaults(), cueing_params(None))
    assert defaults().tilt_rate_limit == pytest.approx(math.radians(3.0))


def test_any_part_of_the_group_may_be_given():
    params = cueing_params({'tilt': {'gain': [0.0, 0.3]}, 'rate': 500})
    assert np.array_equal(params.tilt_gain, [0.0, 0.3]) and params.rate == 500.0
    assert np.array_equal(params.tilt_omega, [2.0, 2.0])
    assert np.array_equal(params.translation_gain, [0.6, 0.6, 0.5])


def test_the_limiter_keys_arrive_by_their_names_without_the_group():
    names = {s.name[len('cueing.'):]: s.default for s in PARAMETER_SPECS
             if s.name[len('cueing.'):].replace('.', '_') not in CueingParams.__dataclass_fields__}
    assert dict(defaults().limiter_settings) == names


@pytest.mark.parametrize('group, key', [
    ({'translation': {'gain': [1.0, 2.0]}}, 'cueing.translation.gain'),
    ({'translation': {'omega': [0.0, 1.0, 1.0]}}, 'cueing.translation.omega'),
    ({'tilt': {'rate_limit': -1.0}}, 'cueing.tilt.rate_limit'),
    ({'limiter': 'clip'}, 'cueing.limiter'),
    ({'rate': 'fast'}, 'cueing.rate'),
    ({'rotation': {'zeta': [1.0, float('nan'), 1.0]}}, 'cueing.rotation.zeta'),
    ({'translation': {'gains': [1.0, 1.0, 1.0]}}, 'cueing.translation.gains'),
    ({'tilt': {}}, 'cueing.tilt'),
])
def test_a_bad_value_is_an_error_naming_its_dotted_key(group, key):
    with pytest.raises(ParameterError) as caught:
        cueing_params(group)
    assert caught.value.key == key


def test_an_unknown_key_suggests_the_closest():
    with pytest.raises(ParameterError, match='cueing.translation.gain'):
        cueing_params_flat({'cueing.translation.gian': [1.0, 1.0, 1.0]})


def test_the_group_must_be_a_mapping():
    with pytest.raises(ParameterError) as caught:
        cueing_params([1, 2])
    assert caught.value.key == 'cueing'


def test_every_spec_is_named_in_the_group_once_and_accepts_its_default():
    names = [s.name for s in PARAMETER_SPECS]
    assert len(names) == len(set(names)) and all(n.startswith('cueing.') for n in names)
    for spec in PARAMETER_SPECS:
        check_value(spec, spec.default)
        assert spec.description


def test_the_values_are_read_only():
    with pytest.raises(ValueError):
        defaults().translation_gain[0] = 2.0
