"""Unit tests of the setpoint intake (flight_sim_dynamics.ros.intake), of the
node configuration it reads, and of the planner motions
(flight_sim_dynamics.machines.staicu.motions)."""
from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.config.files import read_params_sections
from flight_sim_dynamics.config.node_schema import node_schema
from flight_sim_dynamics.config.parameters import NodeConfig
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines.staicu.motions import MOTIONS as STAICU_MOTIONS
from flight_sim_dynamics.machines.staicu.motions import PLANNER_MOTIONS as MOTIONS
from flight_sim_dynamics.machines.staicu.motions import CUEING_DURATION, motion_cueing
from flight_sim_dynamics.ros.diagnostics import CycleStats
from flight_sim_dynamics.ros.intake import STALE_WINDOW, Runtime, SetpointIntake
from flight_sim_dynamics.ros.messages import ACCEL, ERROR, INACTIVE, POSE, SOLVER_ERROR, TWIST, WARN


def field_name(parameter: str) -> str:
    return parameter.replace('.', '_')


# ----------------------------------------------------------------------------
# Configuration
# ----------------------------------------------------------------------------
def test_node_config_matches_schema_and_checks_relations():
    config = NodeConfig.from_values({})
    # (the QoS default, reliable and deep, moved to test_node_params.py:
    # test_default_qos_is_reliable_and_deep; qos.* are rclpy's qos_overrides now)
    # one field per node parameter, derived from the schema, at its default
    assert [f.name for f in dataclasses.fields(NodeConfig)] \
        == [field_name(spec.name) for spec in prm.NODE_PARAMETERS]
    for spec in prm.NODE_PARAMETERS:
        assert getattr(config, field_name(spec.name)) == spec.default, spec.name
    with pytest.raises(prm.ParameterError, match='not a node parameter'):
        NodeConfig.from_values({'qos.depth': 10})
    assert NodeConfig.from_values({'sync.max_pending': 7}).sync_max_pending == 7
    schema = node_schema()
    with pytest.raises(prm.ParameterError) as info:   # limits are model parameters now
        schema.model({**schema.defaults, 'limits.stroke_min': 0.7})
    assert info.value.key == 'limits.stroke_min'
    with pytest.raises(prm.ParameterError):
        NodeConfig.from_values({'estimator.method': 'magic'})
    for spec in prm.NODE_PARAMETERS:
        assert spec.description and prm.check_value(spec, spec.default) == spec.default


def test_node_parameters_in_packaged_yaml():
    values = read_params_sections(prm.default_params_path())
    for spec in prm.NODE_PARAMETERS:
        assert values[spec.name] == spec.default, spec.name


# ----------------------------------------------------------------------------
# Planner motions
# ----------------------------------------------------------------------------
def test_cueing_returns_to_neutral_and_derivatives_are_consistent():
    t = np.linspace(0.0, CUEING_DURATION, 13001)
    q, qd, qdd = motion_cueing(t)
    np.testing.assert_allclose(q[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(q[-1], 0.0, atol=1e-12)
    np.testing.assert_allclose(qd[-1], 0.0, atol=1e-12)
    h = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, h, axis=0)[1:-1], qd[1:-1], atol=1e-4)
    # (jerk jumps at segment ends: the central difference is off by ~h jerk / 2 there)
    np.testing.assert_allclose(np.gradient(qd, h, axis=0)[1:-1], qdd[1:-1], atol=2e-2)
    assert np.abs(q).max(axis=0)[2] > 0.1                     # it does roll


def test_planner_sequence_continuous():
    seq = PlannerSequence(STAICU_MOTIONS, list(MOTIONS), loop=True)
    assert seq.period == pytest.approx(3 * 4.0 + CUEING_DURATION)
    t = np.arange(0.0, 2 * seq.period, 0.005)
    q = np.array([seq.sample(x)[0] for x in t])
    assert np.abs(np.diff(q, axis=0)).max() < 5e-3            # no jumps in position
    assert not seq.finished(100.0)
    once = PlannerSequence(STAICU_MOTIONS, ['general'])
    assert once.period == 3.0 and once.finished(3.01) and not once.finished(3.0)


# -- the rclpy-free modules of ros/ -------------------------------------------------
@pytest.mark.ros
def test_setpoint_helpers_do_not_import_rclpy():
    """The rclpy-free modules of the ROS adapter stay importable (and
    testable) without rclpy."""
    import subprocess
    import sys
    from pathlib import Path
    modules = ['messages', 'join', 'diagnostics', 'intake', 'markers']
    code = ('import sys\n' + ''.join(f'import flight_sim_dynamics.ros.{m}\n' for m in modules)
            + "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))")
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, cwd=root)
    assert out.stdout.strip() == '[]'


# -- activation: what a stream published while the node was inactive ------------
def _stamped(stamp_ns: int, **fields: float) -> SimpleNamespace:
    """A pose/twist/accel message of the shape the intake reads."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    vec = SimpleNamespace(x=0.0, y=0.0, z=0.0)
    return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=nanosec)),
                           pose=SimpleNamespace(position=vec, orientation=SimpleNamespace(
                               x=0.0, y=0.0, z=0.0, w=1.0)),
                           twist=SimpleNamespace(linear=vec, angular=vec),
                           accel=SimpleNamespace(linear=vec, angular=vec))


def _answered(intake: SetpointIntake, stamp_ns: int, now: float) -> bool:
    answers = []
    for kind in (POSE, TWIST, ACCEL):
        answers += intake.receive(kind, _stamped(stamp_ns), now, None)[0]
    return any(a.header == divmod(stamp_ns, 1_000_000_000) for a in answers)


@pytest.mark.parametrize('stream_while_inactive, connected', [
    (True, False), (False, True), (False, False)])
def test_setpoints_stamped_before_an_activation_are_stale_for_a_while(stream_while_inactive,
                                                                       connected):
    """A stream that ran while the node was inactive (seen by the node, or only
    a planner connected: its messages delivered after the activation): for
    STALE_WINDOW s after the activation its setpoints stamped before it are
    dropped (counted inactive), later ones answered; with neither, old stamps
    are answered."""
    intake = SetpointIntake(Runtime(fsd.load_model(), NodeConfig.from_values({})))
    activation = 1_700_000_000 * 1_000_000_000
    if stream_while_inactive:
        intake.receive(POSE, _stamped(activation - 10 ** 9), 0.0, None, active=False)
    intake.activate(activation, now=100.0, connected=connected)
    stale = _answered(intake, activation - 5 * 10 ** 8, 100.5)
    dropped = stream_while_inactive or connected
    assert stale != dropped
    assert intake.stats.rejected.get(INACTIVE, 0) == (
        4 if stream_while_inactive else 3 if connected else 0)
    assert _answered(intake, activation + 10 ** 6, 100.6)
    # after the window, an old stamp is judged by the usual rules only (here: it
    # precedes the last answered one)
    assert not _answered(intake, activation - 10 ** 8, 100.0 + STALE_WINDOW + 0.1)
    assert intake.stats.rejected.get(INACTIVE, 0) == (
        4 if stream_while_inactive else 3 if connected else 0)


# -- the answer first ------------------------------------------------------------------
def test_an_answer_goes_out_before_its_checks_and_statistics():
    """With a publish callback, each answer is handed over as soon as it is
    solved: the intake has not counted it yet (its limit checks and statistics
    come after, off the round trip), and the outcome carries no answers."""
    handed = []
    intake = SetpointIntake(Runtime(fsd.load_model(), NodeConfig.from_values({})),
                            publish=lambda a: handed.append((a.header, intake.stats.answered)))
    stamp = 1_700_000_000 * 1_000_000_000
    outcomes = [intake.receive(kind, _stamped(stamp), 0.0, None) for kind in (POSE, TWIST, ACCEL)]
    assert handed == [(divmod(stamp, 1_000_000_000), 0)]
    assert intake.stats.answered == 1
    assert all(answers == [] for answers, _ in outcomes)


def test_an_answer_that_cannot_go_out_is_counted_and_logged():
    """A publish callback that raises: the setpoint is a ``solver_error``, and
    the outcome carries its ERROR line (the node logs it); the next is tried."""
    def refuse(answer):
        raise RuntimeError('publisher gone')
    intake = SetpointIntake(Runtime(fsd.load_model(), NodeConfig.from_values({})),
                            publish=refuse)
    stamp = 1_700_000_000 * 1_000_000_000
    lines = []
    for k in range(2):
        for kind in (POSE, TWIST, ACCEL):
            lines += intake.receive(kind, _stamped(stamp + k * 10 ** 7), 0.0, None)[1]
    assert intake.stats.rejected.get(SOLVER_ERROR, 0) == 2
    assert intake.stats.answered == 0
    assert [level for level, _ in lines].count(ERROR) >= 1


# -- actuator and joint limits: the machine's own rule ----------------------------------
def _hexapod(**limits):
    """The packaged hexapod with some limits changed."""
    model = fsd.load_model('stewart_6dof')
    return dataclasses.replace(model, limits=dataclasses.replace(model.limits, **limits))


def _stats_after_home(model) -> tuple[CycleStats, list[tuple[int, str]]]:
    """The intake's statistics and log lines after one setpoint at rest at home."""
    intake = SetpointIntake(Runtime(model, NodeConfig.from_values({})))
    stamp, lines, answers = 1_700_000_000 * 1_000_000_000, [], []
    for kind in (POSE, TWIST, ACCEL):
        got, more = intake.receive(kind, _stamped(stamp), 0.0, None)
        answers += got
        lines += more
    assert len(answers) == 1                    # published anyway
    return intake.stats, lines


def test_a_hexapod_beyond_its_u_joint_limit_is_an_exceeded_limit():
    """The U-joints at home (about 0.5 rad) beyond ``limits.u_joint_max_angle``:
    the solve's status is limit, and the node counts the answer as a limit
    exceeded, at ERROR, as it does a stroke, speed or force."""
    model = _hexapod(u_joint_max_angle=0.30)
    zero = [0.0] * 6
    assert fsd.solve(model, zero, zero, zero).status is Status.LIMIT
    stats, lines = _stats_after_home(model)
    assert stats.limit_exceeded == 1 and stats.near_limit == 0
    level, _, values = stats.report(1.0)
    assert level == ERROR and dict(values)['limit exceeded'] == '1'
    assert ERROR in [lvl for lvl, _ in lines]


def test_a_hexapod_near_its_spherical_joint_limit_is_near_a_limit():
    """A joint angle within ``limits.warn_fraction`` of its limit: WARN, near limit."""
    home = fsd.solve(_hexapod(), [0.0] * 6, [0.0] * 6, [0.0] * 6).spherical_angles.max()
    stats, _ = _stats_after_home(_hexapod(spherical_joint_max_angle=home / 0.95))
    assert stats.limit_exceeded == 0 and stats.near_limit == 1
    assert stats.report(1.0)[0] == WARN
    assert _stats_after_home(_hexapod(spherical_joint_max_angle=home / 0.5))[0].near_limit == 0
