"""Property tests of the parameter-file loader (issue 12 #10): random
mutations of the packaged file (deleted, duplicated, misspelt or retyped
keys, random bytes, huge numbers, aliases, YAML 1.1 forms) give a model or a
ParameterError, never another exception. Inputs are bounded in size, so each
example is bounded in time (no timing assertion)."""
import string
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.errors import ParameterError
from flight_sim_dynamics.config.scenes import load_scene

ROOT = Path(__file__).resolve().parents[2]
PACKAGED = (ROOT / 'config' / 'flight_sim_dynamics.yaml').read_text()
SCENE = (ROOT / 'config' / 'scenes' / 'payload.yaml').read_text()

ODD_VALUES = ['1:30', '0x10', '0b1', '010', 'yes', 'off', '~', '', '1_0', '2001-01-01', 'nan',
              '.nan', '.inf', '-.inf', '1e400', '1' + '0' * 400, '9' * 5000, '&a 1', '*a',
              '!!float 1', '[]', '{}', '[1, [2]]', '"x"', "'", '[', '{a: 1}', '-1.0', '0.0',
              '1.0e308', '-1e308', 'true', '[1.0, 2.0]', '? x', '|', '>', '%TAG', '@', '`']
settings.register_profile('loader', max_examples=150, deadline=None,
                          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                 HealthCheck.too_slow])


def _load(tmp_path, content: bytes, scene: bool = False) -> None:
    path = tmp_path / 'fuzz.yaml'
    path.write_bytes(content)
    try:
        if scene:
            load_scene(path)
        else:
            fsd.load_model(path)
    except ParameterError:
        pass


@st.composite
def mutated(draw, text: str) -> bytes:
    """``text`` with 1-4 line mutations, as bytes."""
    lines = [line.encode() for line in text.splitlines(keepends=True)]
    for _ in range(draw(st.integers(1, 4))):
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(['delete', 'duplicate', 'value', 'key', 'indent', 'bytes']))
        line = lines[i]
        head, colon, tail = line.partition(b':')
        if op == 'delete':
            del lines[i]
        elif op == 'duplicate':
            lines.insert(i, line)
        elif op == 'value' and colon:
            lines[i] = head + b': ' + draw(st.sampled_from(ODD_VALUES)).encode() + b'\n'
        elif op == 'key' and colon and head.strip():
            key = head.strip()
            j = draw(st.integers(0, len(key) - 1))
            letter = draw(st.sampled_from(string.ascii_lowercase + '_.*&!')).encode()
            lines[i] = head.replace(key, key[:j] + letter + key[j + 1:]) + b':' + tail
        elif op == 'indent':
            lines[i] = draw(st.sampled_from([b'', b' ', b'\t', b'      '])) + line.lstrip()
        elif op == 'bytes':
            k = draw(st.integers(0, len(line)))
            lines[i] = line[:k] + draw(st.binary(max_size=40)) + line[k:]
    return b''.join(lines)


@settings.get_profile('loader')
@given(content=mutated(PACKAGED))
def test_mutated_parameter_file_is_a_model_or_a_parameter_error(tmp_path, content):
    _load(tmp_path, content)


@settings.get_profile('loader')
@given(content=mutated(SCENE))
def test_mutated_scene_file_is_a_scene_or_a_parameter_error(tmp_path, content):
    _load(tmp_path, content, scene=True)


@settings.get_profile('loader')
@given(content=st.binary(max_size=2000))
def test_random_bytes_are_a_parameter_error(tmp_path, content):
    _load(tmp_path, content)


@settings.get_profile('loader')
@given(prefix=st.integers(0, len(PACKAGED)), depth=st.integers(1, 12),
       fan=st.integers(2, 12))
def test_alias_bombs_anywhere_are_a_parameter_error(tmp_path, prefix, depth, fan):
    bomb = 'a0: &a0 [x, x]\n' + ''.join(
        f'a{i}: &a{i} [' + ', '.join([f'*a{i - 1}'] * fan) + ']\n' for i in range(1, depth))
    content = (PACKAGED[:prefix] + '\n' + bomb + PACKAGED[prefix:]).encode()
    path = tmp_path / 'bomb.yaml'
    path.write_bytes(content)
    try:
        fsd.load_model(path)
    except ParameterError:
        return
    raise AssertionError('an alias bomb was accepted')


@settings.get_profile('loader')
@given(value=st.one_of(st.integers(min_value=-10 ** 500, max_value=10 ** 500),
                       st.floats(allow_nan=True, allow_infinity=True),
                       st.text(max_size=30), st.booleans(),
                       st.lists(st.floats(), max_size=12)),
       where=st.sampled_from(['gravity', 'bodies.rod.mass', 'bodies.platform.com',
                              'bodies.rod.inertia', 'output.frame_id', 'sync.max_pending',
                              'payload.inertia', 'scene', 'estimator.method']))
def test_any_value_of_any_parameter_is_a_model_or_a_parameter_error(tmp_path, value, where):
    *groups, leaf = where.split('.')
    text = repr(value) if not isinstance(value, str) else '"' + value.replace('\\', '\\\\') \
        .replace('"', '\\"') + '"'
    text = text.replace('True', 'true').replace('False', 'false').replace('nan', '.nan') \
        .replace('inf', '.inf')
    body = ''
    for depth, group in enumerate(groups):
        body += '  ' * (depth + 2) + f'{group}:\n'
    body += '  ' * (len(groups) + 2) + f'{leaf}: {text}\n'
    _load(tmp_path, ('flight_sim_dynamics:\n  ros__parameters:\n' + body).encode())
