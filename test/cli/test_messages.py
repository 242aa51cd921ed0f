"""What the command line says of numbers at the edge of the floating-point range
and of huge values (issue 29): no numpy RuntimeWarning (with its site-packages
source lines) reaches the user, an error blames the value the user wrote (its
file, line and column) and not a rate estimated from it, and a huge value is
echoed cut short."""
from __future__ import annotations

import warnings
from pathlib import Path

import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.config.errors import ParameterError

ROOT = Path(__file__).resolve().parents[2]
HEXAPOD_FILE = str(ROOT / 'config' / 'stewart_6dof.yaml')


def run(argv: list[str], capsys) -> tuple[int, str, str]:
    """Exit status, standard error and output of the command, no warning of any kind allowed."""
    capsys.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        status = main(argv)
    assert not caught, [str(w.message) for w in caught]
    out, err = capsys.readouterr()
    assert 'RuntimeWarning' not in err and 'site-packages' not in err and 'Traceback' not in err
    return status, err, out


def error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.startswith('error: ')]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize('header, row, blamed', [
    ('t,surge,heave,roll', '0.01,1e308,0,0', 'surge'),              # rates estimated
    ('t,surge,heave,roll', '0.01,0,-1e308,0', 'heave'),
    ('t,surge,heave,roll,surge_rate,heave_rate,roll_rate,surge_acc,heave_acc,roll_acc',
     '0.01,1e308,0,0,0,0,0,0,0,0', 'surge'),                       # the spline overflows
    ('t,surge,heave,roll,surge_rate,heave_rate,roll_rate,surge_acc,heave_acc,roll_acc',
     '0.01,0,0,0,0,0,0,0,1e308,0', 'heave_acc'),
])
def test_a_huge_reference_value_is_blamed_where_the_user_wrote_it(tmp_path, capsys, header,
                                                                  row, blamed):
    zeros = ','.join(['0'] * len(header.split(',')[1:]))
    path = tmp_path / 'ref.csv'
    path.write_text(f'{header}\n0,{zeros}\n{row}\n0.02,{zeros}\n0.03,{zeros}\n')
    status, err, _ = run(['simulate', '--reference', str(path), '-o', str(tmp_path / 's.csv')],
                      capsys)
    line = error_line(err)
    assert status == 2 and f'{path}, line 3' in line and f'{blamed} = ' in line, line
    assert 'qd[' not in line and not (tmp_path / 's.csv').exists()


@pytest.mark.parametrize('rows, line, blamed', [
    (['0,1,1,1', '0,1,1,1', '1,1,1,1'], 3, 't'),                     # t does not increase
    (['0,1,1,1', '1e308,1,1,1'], 3, 't'),                            # too many steps
    (['0,1,1,1', '1,1,-1e308,1', '2,1,1,1'], 3, 'force_b'),           # the spline overflows
])
def test_force_history_errors_name_file_line_and_column(tmp_path, capsys, rows, line, blamed):
    path = tmp_path / 'forces.csv'
    path.write_text('t,force_a,force_b,force_c\n' + '\n'.join(rows) + '\n')
    status, err, _ = run(['simulate', '--forces', str(path), '-o', str(tmp_path / 's.csv')], capsys)
    message = error_line(err)
    assert status == 2 and f'{path}, line {line}' in message and f'{blamed} = ' in message, \
        message


@pytest.mark.parametrize('params, legs', [([], 3), (['--params', HEXAPOD_FILE], 6)],
                         ids=['3-DOF', 'hexapod'])
@pytest.mark.parametrize('length', ['1e308', '1e300'])
def test_forward_of_huge_lengths_warns_nobody(capsys, params, legs, length):
    status, _, out = run(['forward', *params] + [length] * legs, capsys)
    assert status == 1 and 'status=' in out and 'status=ok' not in out


@pytest.mark.parametrize('key, value', [
    ('home', '[0.0, 0.0, 1.0e300]'),
    ('base_joints', '[' + ', '.join(['1.0e300'] * 18) + ']'),
    ('platform_joints', '[' + ', '.join(['1.0e300', '-1.0e300', '0.0'] * 6) + ']'),
    ('base_axes', '[' + ', '.join(['1.0e300', '1.0', '0.0'] * 6) + ']'),
])
def test_a_geometry_beyond_the_float_range_is_a_parameter_error(tmp_path, key, value):
    path = tmp_path / 'big.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    machine: stewart_6dof\n'
                    f'    geometry:\n      {key}: {value}\n')
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        with pytest.raises(ParameterError) as info:
            fsd.load_model(path)
    assert info.value.key == f'geometry.{key}' and str(path) in str(info.value)


@pytest.mark.parametrize('key', ['machine', 'scene'])
def test_a_huge_name_is_echoed_cut_short(tmp_path, capsys, key):
    path = tmp_path / 'p.yaml'
    line = f'    {key}: ' + 'x' * 200_000 + '\n'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n'
                    + ('    machine: stewart_6dof\n' if key == 'scene' else '') + line)
    status, err, _ = run(['solve', str(tmp_path / 'in.csv'), '-o', str(tmp_path / 'o.csv'),
                       '--params', str(path)], capsys)
    message = error_line(err)
    assert status == 2 and len(message) < 1000 and 'characters)' in message, len(message)
    assert key == 'scene' or str(path) in message
