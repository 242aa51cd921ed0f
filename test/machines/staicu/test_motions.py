"""The one motion registry (flight_sim_dynamics.machines.staicu.motions), the one
sample_times, the node-process helpers (ros/process.py) and the demo's live
summary line."""
from __future__ import annotations

import re
import sys
import time

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.demo import LiveSummary
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.machines.staicu import motions, trajectories
from flight_sim_dynamics.ros import process


def test_registry_holds_every_motion_once():
    assert list(motions.MOTIONS) == ['vertical', 'rectilinear', 'general', 'cueing', 'violent']
    assert motions.PLANNER_MOTIONS == ('vertical', 'rectilinear', 'general', 'cueing')
    assert motions.TEST_MOTIONS == ('vertical', 'rectilinear', 'general', 'violent')
    for name, m in motions.MOTIONS.items():
        assert m.name == name and m.duration > 0 and m.description
    assert motions.duration('cueing') == motions.CUEING_DURATION
    assert motions.duration('violent') == motions.VIOLENT_DURATION
    assert motions.duration('general') == trajectories.DURATION
    with pytest.raises(ValueError) as info:           # names the motion and the choices
        motions.motion('nope', 0.0)
    assert all(w in str(info.value) for w in ('nope', *motions.MOTIONS)), info.value


def test_paper_motions_are_eq6_through_the_registry_and_the_public_module():
    t = np.linspace(0.0, 3.0, 31)
    for name in trajectories.PAPER_EXAMPLES:
        a = motions.motion(name, t)
        b = fsd.trajectories.paper_example(name, t)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
    # eq. (6): q = amplitude (1 - cos(pi t / 3)); at t = 3 s twice the amplitude
    q = motions.motion('general', 3.0)[0][0]
    np.testing.assert_allclose(q, 2 * np.array(fsd.trajectories.PAPER_EXAMPLES['general']))


def test_one_sample_times_rate_first():
    assert motions.sample_times is trajectories.sample_times
    np.testing.assert_allclose(trajectories.sample_times(10.0, 0.5), np.arange(6) / 10.0)
    assert len(trajectories.sample_times(100.0)) == 301          # default: the paper's 3 s
    t, q, qd, qdd = motions.MOTIONS['violent'].sampled(1000.0)
    assert len(t) == 3001 and q.shape == qd.shape == qdd.shape == (3001, 3)
    with pytest.raises(ValueError, match='rate must be a positive'):
        trajectories.sample_times(0.0)


def test_violent_motion_is_violent_reachable_and_exact():
    t = np.arange(3001) / 1000.0
    q, qd, qdd = motions.violent_motion(t)
    assert np.abs(qdd[:, :2]).max() > 0.9 * 9.81          # about 1 g
    assert np.abs(qdd[:, 2]).max() > 15.0                  # about 20 rad/s^2
    assert np.abs(q[:, :2]).max() <= 0.1 + 1e-12
    assert np.abs(q[:, 2]).max() <= 0.3 + 1e-12
    for k in (0, -1):                                      # from rest to rest
        assert np.abs(q[k]).max() < 1e-12 and np.abs(qd[k]).max() < 1e-12
    sol = fsd.solve_batch(fsd.load_model(), q, qd, qdd)    # reachable
    assert not np.isin(sol.status, [fsd.Status.UNREACHABLE, fsd.Status.INVALID_INPUT]).any()
    assert np.isfinite(sol.force).all()
    h = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, h, axis=0)[1:-1], qd[1:-1], atol=2e-3)
    # (the jerk jumps where a step starts or ends: central differences are off there)
    np.testing.assert_allclose(np.gradient(qd, h, axis=0)[1:-1], qdd[1:-1], atol=0.5)


def test_planner_returns_to_neutral_only_after_motions_that_end_away_from_it():
    seq = PlannerSequence(motions.MOTIONS, ['general', 'cueing', 'violent', 'vertical'])
    labels = [s[0] for s in seq.segments]
    assert labels == ['general', 'return', 'cueing', 'violent', 'vertical']
    looped = PlannerSequence(motions.MOTIONS, ['general', 'cueing'], loop=True)
    assert [s[0] for s in looped.segments] == ['general', 'return', 'cueing']


def _rate(line: str) -> float:
    return float(re.search(r'rate\s+([-\d.]+) Hz', line).group(1))


def test_demo_live_summary_has_no_final_line_at_zero_rate():
    live = LiveSummary(100.0)
    first = live.line(101.0, 100, [1.0, 2.0, 3.0], 'OK')
    assert _rate(first) == 100.0 and 'OK' in first
    assert all(f'{f:.2f}' in first for f in (1.0, 2.0, 3.0))
    assert live.line(101.0, 100, [1.0, 2.0, 3.0], 'OK', final=True) is None
    last = live.line(101.5, 150, [1.0, 2.0, 3.0], 'OK', final=True)
    assert _rate(last) == 100.0
    # a run too short for a periodic line still ends with one
    assert LiveSummary(0.0).line(0.5, 0, None, 'no diagnostics yet', final=True) is not None


def test_node_command_and_environment():
    cmd = process.node_command('p.yaml', ['-p', 'a:=1'], executor='single')
    assert cmd == [*process.python_module('flight_sim_dynamics.ros.node'), '--executor', 'single',
                   '--ros-args', '--params-file', 'p.yaml', '-p', 'a:=1']
    assert process.node_command(None, launcher=['x'])[0:2] == ['x', '--ros-args']
    env = process.node_env({'PYTHONPATH': 'elsewhere'})
    assert env['PYTHONPATH'].split(':') == [process.PACKAGE_PARENT, 'elsewhere']
    assert env['PYTHONUNBUFFERED'] == '1'


@pytest.mark.ros
def test_start_and_stop_a_process_group(tmp_path):
    """start_node runs the command in its own session and stop_node ends it."""
    log = tmp_path / 'node.log'
    proc = process.start_node(None, log=log, launcher=[
        sys.executable, '-c', 'import sys, time; print(sys.argv[1:], flush=True); '
        'time.sleep(60)'])
    try:
        deadline = time.monotonic() + 20.0
        while '--ros-args' not in log.read_text() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None
    finally:
        rc = process.stop_node(proc, timeout=5.0)
    assert rc is not None and rc != 0                 # interrupted
    assert "['--ros-args']" in log.read_text()
    assert process.stop_node(proc) == rc              # stopping again changes nothing
