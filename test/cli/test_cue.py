"""``flight-sim-dynamics cue``: a vehicle log through the cueing planner into
the machine's trajectory CSV (what ``solve`` reads), the report and figure, and
bad logs (one ``error:`` line naming the line, exit status 2, no output)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.columns import trajectory_columns
from flight_sim_dynamics.cli.cue import VEHICLE_COLUMNS
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.config.machine_files import load_cueing
from flight_sim_dynamics.cueing.planner import run
from test_cli import one_error_line, run_cli

ROOT = Path(__file__).resolve().parents[2]
HEXAPOD = str(ROOT / 'config' / 'stewart_6dof.yaml')


def read(path: Path) -> csv_io.Table:
    return csv_io.read_csv(path, required=(), allow_extra=True, text_columns=('status',))


@pytest.fixture(scope='module')
def braking(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp('vehicle') / 'braking.csv'
    assert main(['cue', '--example', 'braking', '--rate', '200', '-o', str(path)]) == 0
    return path


@pytest.fixture(scope='module')
def stop(braking, tmp_path_factory) -> Path:
    """The example's first 6 s: cruise, then braking from 3 s."""
    table = read(braking)
    path = tmp_path_factory.mktemp('vehicle') / 'stop.csv'
    csv_io.write_csv(path, table.names, table.data[table['t'] <= 6.0])
    return path


def test_the_example_writes_a_vehicle_log(braking):
    table = read(braking)
    assert table.names == VEHICLE_COLUMNS
    assert len(table) == 14 * 200 + 1
    np.testing.assert_allclose(table.data[0, 1:], [0.0, 0.0, 9.80665, 0.0, 0.0, 0.0])


def test_the_output_is_the_planners_run_in_the_machines_trajectory_columns(braking, tmp_path,
                                                                           capsys):
    out = tmp_path / 'platform.csv'
    assert main(['cue', str(braking), '-o', str(out), '--params', HEXAPOD,
                 '--limiter', 'none']) == 0
    line = capsys.readouterr().out
    assert line.startswith(f'cue: {out}: ') and 'limiter none' in line
    table, vehicle = read(out), read(braking)
    model = fsd.load_model(HEXAPOD)
    assert table.names == trajectory_columns(fsd.machine_of(model))
    params = load_cueing(HEXAPOD).replace(limiter='none')
    expected = run(model, params, vehicle['t'], vehicle.data[:, 1:4], vehicle.data[:, 4:])
    np.testing.assert_array_equal(table.data, np.column_stack([expected.t, expected.q,
                                                               expected.qd, expected.qdd]))
    assert np.allclose(np.diff(table['t']), 1.0 / params.rate)


def test_the_three_dof_machine_gets_its_channels_and_solve_reads_them_all_ok(stop, tmp_path,
                                                                           capsys, monkeypatch):
    """Its params file plans the preview (L8): a long log reports the
    preview's passes, then the output's samples.
    """
    import os

    from flight_sim_dynamics.cli import cue
    monkeypatch.setattr(cue, 'LONG_RUN', 2000)
    monkeypatch.setattr(os, 'sched_getaffinity', lambda pid: {0})      # one process
    out, solved = tmp_path / 'platform.csv', tmp_path / 'solved.csv'
    assert main(['cue', str(stop), '-o', str(out)]) == 0
    captured = capsys.readouterr()
    assert 'not cued: sway, pitch, yaw' in captured.out
    assert 'preview' in captured.out.splitlines()[0]        # the result line says so
    lines = captured.err.splitlines()
    passes = [line for line in lines if ': preview pass ' in line]
    assert passes and passes[0].startswith(f'cue: {out}: preview pass 1: 0/6001 samples')
    assert lines[-1].startswith(f'cue: {out}: 6001/6001 samples (100%')
    assert read(out).names == trajectory_columns(fsd.machine_of(fsd.load_model()))
    assert main(['solve', str(out), '-o', str(solved)]) == 0
    assert set(read(solved).text['status']) == {'ok'}


def test_report_and_figure(stop, tmp_path, capsys):
    out, md, png = tmp_path / 'p.csv', tmp_path / 'cue.md', tmp_path / 'cue.png'
    assert main(['cue', str(stop), '-o', str(out), '--params', HEXAPOD, '--report', str(md),
                 '--plot', str(png)]) == 0
    line = capsys.readouterr().out
    assert 'felt specific force RMSE' in line and 'solver: ok ' in line
    text = md.read_text()
    for heading in ('## Cues at the head', '## Actuators', '## Limiter'):
        assert heading in text
    assert text.count('\n| ') >= 9 + 7
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def _log(path: Path, rows: list[str], header: str = ','.join(VEHICLE_COLUMNS)) -> Path:
    path.write_text(header + '\n' + '\n'.join(rows) + '\n')
    return path


REST = '0,0,9.80665,0,0,0'


@pytest.mark.parametrize('rows, line', [
    ([f'0,{REST}', f'0.01,{REST}', f'0.005,{REST}', f'0.02,{REST}'], 4),    # t backwards
    ([f'0,{REST}', f'0.01,{REST}', '0.02,nan,0,9.8,0,0,0', f'0.03,{REST}'], 4),  # NaN
    ([f'0,{REST}', f'0.01,{REST}', '0.02,0,0,9.8,0,0'], 4),                   # a cell short
])
def test_a_bad_log_is_one_error_naming_its_line_and_writes_nothing(tmp_path, capsys, rows, line):
    out = tmp_path / 'p.csv'
    assert main(['cue', str(_log(tmp_path / 'v.csv', rows)), '-o', str(out)]) == 2
    message = one_error_line(capsys.readouterr().err)
    assert f'line {line}' in message
    assert not out.exists()


def test_repeated_times_are_dropped_and_counted_extra_columns_ignored(tmp_path, capsys):
    rows = [f'0,{REST},1', f'0.01,{REST},2', f'0.01,{REST},3', '0.02,0.5,0,9.80665,0,0,0,4']
    log = _log(tmp_path / 'v.csv', rows, ','.join(VEHICLE_COLUMNS) + ',throttle')
    out = tmp_path / 'p.csv'
    assert main(['cue', str(log), '-o', str(out), '--limiter', 'none']) == 0
    err = capsys.readouterr().err
    assert "ignoring column 'throttle'" in err and '1 repeated time(s) dropped' in err
    assert len(read(out)) == 21


def test_a_bad_cueing_group_is_an_error_naming_its_key(braking, tmp_path, capsys):
    params = tmp_path / 'p.yaml'
    params.write_text(Path(HEXAPOD).read_text().replace('rate: 1000.0', 'rate: -3.0'))
    assert main(['cue', str(braking), '-o', str(tmp_path / 'o.csv'),
                 '--params', str(params)]) == 2
    assert 'cueing.rate' in one_error_line(capsys.readouterr().err)


def test_no_log_and_no_example_is_an_error(tmp_path, capsys):
    assert main(['cue', '-o', str(tmp_path / 'o.csv')]) == 2
    assert 'VEHICLE_CSV' in one_error_line(capsys.readouterr().err)


@pytest.mark.ros
def test_as_a_user_runs_it_a_violent_log_on_the_hexapod_solves_all_ok(tmp_path):
    log, out, solved = tmp_path / 'violent.csv', tmp_path / 'p.csv', tmp_path / 's.csv'
    assert run_cli('cue', '--example', 'violent', '--rate', '500', '-o', str(log)).returncode == 0
    done = run_cli('cue', str(log), '-o', str(out), '--params', HEXAPOD)
    assert done.returncode == 0, done.stderr
    assert run_cli('solve', str(out), '-o', str(solved), '--params', HEXAPOD).returncode == 0
    assert set(read(solved).text['status']) == {'ok'}


def test_an_npz_output_holds_the_same_columns(braking, tmp_path):
    csv, npz = tmp_path / 'p.csv', tmp_path / 'p.npz'
    for out in (csv, npz):
        assert main(['cue', str(braking), '-o', str(out), '--limiter', 'none']) == 0
    with np.load(npz) as data:
        table = read(csv)
        assert tuple(data['names']) == table.names
        for name in table.names:
            np.testing.assert_array_equal(data[name], table[name])


def test_to_standard_output_the_data_alone(braking, capsys):
    assert main(['cue', str(braking), '-o', '-', '--limiter', 'none']) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[0] == ','.join(trajectory_columns(fsd.machine_of(fsd.load_model())))
    assert len(out.splitlines()) == 14 * 1000 + 2 and err.startswith('cue: -: ')


@pytest.mark.ros            # forks the washout's and the CSV formatter's processes
@pytest.mark.parametrize('suffix', ['csv', 'npz'])
def test_a_long_log_is_cued_in_three_processes_into_the_same_file(braking, tmp_path,
                                                                  monkeypatch, suffix):
    """From LONG_RUN samples on (two cores or more) the washout and the CSV's
    formatting run in processes of their own: the same output."""
    import multiprocessing
    import os

    from flight_sim_dynamics.cli import cue
    alone = tmp_path / f'alone.{suffix}'
    assert main(['cue', str(braking), '-o', str(alone), '--params', HEXAPOD]) == 0
    calls = []

    def spy(*args, **kwargs):
        calls.append(kwargs['parallel'])
        return run(*args, **kwargs)
    monkeypatch.setattr(cue, 'LONG_RUN', 5000)
    monkeypatch.setattr(cue, 'cue_run', spy)
    monkeypatch.setattr(os, 'sched_getaffinity', lambda pid: {0, 1})
    together = tmp_path / f'together.{suffix}'
    assert main(['cue', str(braking), '-o', str(together), '--params', HEXAPOD]) == 0
    assert calls == [True]
    if suffix == 'csv':
        assert together.read_bytes() == alone.read_bytes()
    else:
        with np.load(alone) as a, np.load(together) as b:
            assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)
    assert multiprocessing.active_children() == []
