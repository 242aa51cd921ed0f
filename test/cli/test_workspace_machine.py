"""A third machine's workspace through the command line with nothing in cli/
changed: a tiny machine (a platform that reaches a disk of a radius its file
gives) registered in the registry (machines/__init__.py) by monkeypatch, its
packaged parameter file in a temporary folder. ``flight-sim-dynamics
workspace`` takes its option, refuses the other machines' ones and theirs
its, and draws, prints and tabulates its survey with the shared code."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import machines as registry
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.config import machine_files
from flight_sim_dynamics.core.machine import Machine
from flight_sim_dynamics.core.workspace import (INSIDE, Cause, End, Option, PlaneMap, Range,
                                                Survey, cell_centres)

NAME = 'disk_2dof'


@dataclass(frozen=True)
class DiskModel:
    name: str
    scene: str
    reach: float


def from_params(params, effects) -> DiskModel:
    return DiskModel(name=params['machine'], scene=params['scene'], reach=float(params['reach']))


def survey(model: DiskModel, *, resolution: int, squash: float = 1.0) -> Survey:
    """Reachable: x^2 + (y / squash)^2 <= reach^2; condition 1 + radius."""
    x = cell_centres(-1.5 * model.reach, 1.5 * model.reach, resolution)
    X, Y = np.meshgrid(x, x)
    radius = np.hypot(X, Y / squash)
    inside = radius <= model.reach
    causes = (INSIDE, Cause('beyond its reach', 'unreachable: beyond the reach', singular=True))
    plane = PlaneMap(title=f'x-y at squash {squash:g}', names=('x', 'y'), units=('m', 'm'),
                     x=x, y=x, cause=np.where(inside, 0, 1), causes=causes,
                     condition=np.where(inside, 1.0 + radius, np.nan),
                     near_singular=np.zeros(X.shape, dtype=bool))
    ends = (End(-model.reach, 'beyond its reach'), End(model.reach, 'beyond its reach'))
    return Survey(title=f'Workspace of {model.name}', notes=('A disk.',), sets=('reachable',),
                  condition_label='radius plus one', condition_name='1 + r',
                  max_condition=100.0, near_singular_rule='never',
                  ranges=(Range('x', 'm', (ends,)),), planes=(plane,))


def check_squash(value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f'needs a finite number above 0, got {value:g}')


DISK = Machine(
    name=NAME, model_type=DiskModel, coordinates=('x', 'y'), units=('m', 'm'), legs=('a', 'b'),
    joints=(), solve=None, solve_batch=None, forward_kinematics=None, forward_dynamics=None,
    actuator_limits=None, limit_usage=None, parameters=frozenset({'machine', 'scene', 'reach'}),
    from_params=from_params, parameter_files=(NAME,), title='disk machine',
    workspace=survey,
    workspace_options=(Option('squash', 'how much y is squashed', type=float,
                              metavar='FACTOR', check=check_squash),))


@pytest.fixture
def disk_machine(monkeypatch, tmp_path):
    """The disk machine in the registry and its packaged file; a user's file naming it."""
    packaged = tmp_path / 'packaged'
    packaged.mkdir()
    (packaged / f'{NAME}.yaml').write_text(
        f'flight_sim_dynamics:\n  ros__parameters:\n    machine: {NAME}\n    reach: 0.5\n')
    real = machine_files.packaged_path
    monkeypatch.setattr(machine_files, 'packaged_path',
                        lambda name: packaged / f'{name}.yaml' if name == NAME else real(name))
    monkeypatch.setattr(registry, 'MACHINES', registry.MACHINES + (DISK,))
    monkeypatch.setitem(registry.BY_MODEL_TYPE, DiskModel, DISK)
    monkeypatch.setitem(registry.PACKAGED, NAME, DISK)
    params = tmp_path / 'mine.yaml'
    params.write_text(f'flight_sim_dynamics:\n  ros__parameters:\n    machine: {NAME}\n'
                      '    reach: 0.4\n')
    return params


def test_a_third_machine_is_drawn_printed_and_tabulated_by_the_shared_code(
        disk_machine, tmp_path, capsys):
    png, md = tmp_path / 'disk.png', tmp_path / 'disk.md'
    assert main(['workspace', '--params', str(disk_machine), '-o', str(png), '--markdown',
                 str(md), '--resolution', '40', '--squash', '0.5']) == 0
    out = capsys.readouterr().out
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    page = md.read_text()
    assert page.startswith(f'# Workspace of {NAME}')
    assert '| x | -0.400 m | +0.400 m | beyond its reach | beyond its reach |' in page
    assert 'x-y at squash 0.5' in page and 'x-y at squash 0.5' in out
    # the area the shared code counts is the ellipse's (its file's reach, the option's squash)
    area = float(next(line for line in page.splitlines() if line.startswith('| x-y at'))
                 .split('|')[2].split()[0])
    assert area == pytest.approx(math.pi * 0.4 * 0.2, rel=0.1)
    assert 'beyond its reach 100 %' in page


@pytest.mark.parametrize('params, option', [
    ('disk', ['--rolls', '10']), ('disk', ['--at', '0', '0', '0', '0']),
    (None, ['--squash', '2']), ('config/stewart_6dof.yaml', ['--squash', '2'])])
def test_each_machine_refuses_the_others_options(disk_machine, tmp_path, capsys, params,
                                                 option):
    argv = ['workspace', '-o', str(tmp_path / 'w.png'), '--resolution', '20'] + option
    argv += ['--params', str(disk_machine) if params == 'disk' else params] if params else []
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f'error: {option[0]}: not an option'), err
    assert not (tmp_path / 'w.png').exists()


def test_a_bad_value_of_its_option_is_refused_before_any_computation(disk_machine, tmp_path,
                                                                     capsys):
    assert main(['workspace', '--params', str(disk_machine), '-o', str(tmp_path / 'w.png'),
                 '--squash', 'inf']) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: --squash needs a finite'), err
    assert not (tmp_path / 'w.png').exists()


def test_without_the_registry_entry_the_option_does_not_exist(tmp_path, capsys):
    assert main(['workspace', '-o', str(tmp_path / 'w.png'), '--squash', '2']) == 2
    assert 'unrecognized arguments: --squash' in capsys.readouterr().err
    assert fsd.machine_of(fsd.load_model()).workspace_options     # the 3-DOF machine's own
