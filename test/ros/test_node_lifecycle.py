"""The node as a managed (lifecycle) node, driven over DDS by a plain rclpy
client as `ros2 lifecycle get/set` and a lifecycle manager drive it: the
lifecycle_msgs services get_state, change_state and
get_available_transitions; autostart false starts unconfigured; configure
with bad parameters stays unconfigured and the process up; inactive setpoints
are counted, never answered; shutdown ends the process with exit 0.
"""
from __future__ import annotations

import os
import signal
import time

import pytest
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState

from flight_sim_dynamics.config.parameters import NODE_NAME
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from node_harness import PARAMS_FILE, Client, NodeProcess, stamp_ns

pytestmark = pytest.mark.ros

Q, QD, QDD = (v[0] for v in paper_example('general', [1.0]))


class LifecycleClient(Client):
    """The test client plus the node's lifecycle services."""

    def __init__(self, namespace: str) -> None:
        super().__init__('lifecycle_client', namespace=namespace)
        target = f'{namespace}/{NODE_NAME}'
        for name, srv in (('get_state', GetState), ('change_state', ChangeState),
                          ('get_available_transitions', GetAvailableTransitions)):
            self.srv[name] = self.node.create_client(srv, f'{target}/{name}')

    def state(self) -> str:
        return self.call('get_state', GetState.Request()).current_state.label

    def change(self, transition: int) -> bool:
        request = ChangeState.Request(transition=Transition(id=transition))
        return self.call('change_state', request, timeout=10.0).success

    def transitions(self) -> set[str]:
        response = self.call('get_available_transitions', GetAvailableTransitions.Request())
        return {t.transition.label for t in response.available_transitions}

    def answered(self, stamp: int, timeout: float) -> bool:
        """Send one complete setpoint stamped ``stamp``; True if answered."""
        n = len(self.actuator)
        self.send(stamp, Q, QD, QDD)
        return self.spin_until(lambda: any(stamp_ns(m) == stamp
                                           for _, m in self.actuator[n:]), timeout)

    def wait_matched(self) -> None:
        assert self.spin_until(lambda: all(p.get_subscription_count() > 0 for p in (
            self.pose_pub, self.twist_pub, self.accel_pub))
            and self.actuator_sub.get_publisher_count() > 0, 10.0)


def managed(namespace: str, *ros_args: str, executor: str | None = None
            ) -> tuple[NodeProcess, LifecycleClient]:
    proc = NodeProcess('-p', 'autostart:=false', '-p', 'diagnostics.period:=0.2',
                       '-r', f'__ns:={namespace}', *ros_args, params_file=PARAMS_FILE,
                       executor=executor)
    client = LifecycleClient(namespace)
    client.watch = proc
    assert client.spin_until(lambda: client.srv['get_state'].service_is_ready(), 20.0), \
        proc.output()[-3000:]
    return proc, client


def test_full_lifecycle_over_the_services():
    proc, client = managed('/lc')
    try:
        assert client.state() == 'unconfigured'
        assert 'configure' in client.transitions()
        # unconfigured: no endpoints yet (configure creates them)
        assert client.pose_pub.get_subscription_count() == 0
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert client.state() == 'inactive'
        assert {'activate', 'cleanup', 'shutdown'} <= client.transitions()
        client.wait_matched()
        stamp = time.time_ns() - 10 ** 9
        # inactive: counted as `inactive`, never answered (not even after activate)
        assert not client.answered(stamp, 1.0)
        values = client.wait_diagnostics(lambda v: int(v.get('rejected inactive', 0)) >= 3)
        assert values['lifecycle state'] == 'inactive'
        assert 'received while inactive' in values['last rejection'], values
        assert client.change(Transition.TRANSITION_ACTIVATE)
        assert client.state() == 'active'
        assert not client.spin_until(lambda: any(stamp_ns(m) == stamp
                                                 for _, m in client.actuator), 0.5)
        # stamped after the activation (one stamped before it, within a few seconds
        # of it, is a straggler of the stream that ran while inactive: dropped)
        assert client.answered(time.time_ns(), 5.0)
        assert client.wait_diagnostics(lambda v: v['lifecycle state'] == 'active')
        assert client.change(Transition.TRANSITION_DEACTIVATE)
        assert client.state() == 'inactive'
        assert not client.answered(time.time_ns(), 1.0)
        assert client.change(Transition.TRANSITION_CLEANUP)
        assert client.state() == 'unconfigured'
        assert client.spin_until(lambda: client.pose_pub.get_subscription_count() == 0, 5.0)
        # configure again: the same node answers again after activate
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert client.change(Transition.TRANSITION_ACTIVATE)
        client.wait_matched()
        assert client.answered(time.time_ns(), 5.0)
        client.watch = None
        assert client.change(Transition.TRANSITION_ACTIVE_SHUTDOWN)
        proc.proc.wait(10.0)
        assert proc.proc.returncode == 0, proc.output()[-3000:]
    finally:
        client.close()
        proc.stop()
    assert 'Traceback' not in proc.output()


def test_failing_configure_stays_unconfigured_and_up():
    """A bad start-up value: configure fails with the reason logged, the
    process stays up; once the parameter is set, configure succeeds."""
    proc, client = managed('/lcbad', '-p', 'bodies.platform.mass:=-1.0')
    try:
        assert client.state() == 'unconfigured'
        assert not client.change(Transition.TRANSITION_CONFIGURE)
        assert client.state() == 'unconfigured'
        assert proc.alive()
        assert client.spin_until(lambda: 'bodies.platform.mass' in proc.output(), 5.0)
        log = proc.output()
        assert 'configure failed' in log and 'must be > 0' in log, log[-2000:]
        # a wrong value is still refused while unconfigured; a good one is taken
        [refused] = client.set_params({'bodies.platform.mass': -2.0})
        assert not refused.successful and 'bodies.platform.mass' in refused.reason
        [accepted] = client.set_params({'bodies.platform.mass': 5.0})
        assert accepted.successful, accepted.reason
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert client.change(Transition.TRANSITION_ACTIVATE)
        client.wait_matched()
        assert client.answered(time.time_ns(), 5.0)
    finally:
        client.close()
        code = proc.stop()
    assert code == 0
    assert 'Traceback' not in proc.output()


def test_autostart_answers_at_once_and_reports_active(client):
    """The default (autostart true): active from the start."""
    assert client.wait_diagnostics(lambda v: v['lifecycle state'] == 'active')
    client.srv['get_state'] = client.node.create_client(GetState, f'{NODE_NAME}/get_state')
    response = client.call('get_state', GetState.Request(), timeout=10.0)
    assert response.current_state.id == State.PRIMARY_STATE_ACTIVE


def test_invalid_transitions_are_refused_and_the_node_keeps_running():
    """A transition the current state does not have (rclpy raises RCLError
    for it), an unknown id or label: success false, the state unchanged, the
    process up; the valid transitions still work."""
    proc, client = managed('/lcinv')
    try:
        for transition in (Transition(id=Transition.TRANSITION_ACTIVATE),
                           Transition(id=Transition.TRANSITION_DEACTIVATE),
                           Transition(id=200), Transition(label='no_such_transition')):
            response = client.call('change_state', ChangeState.Request(transition=transition),
                                   timeout=10.0)
            assert not response.success, transition
            assert client.state() == 'unconfigured'
            assert proc.alive(), proc.output()[-3000:]
        assert client.change(Transition.TRANSITION_CONFIGURE)
        assert not client.change(Transition.TRANSITION_CONFIGURE)    # inactive: not valid
        assert client.state() == 'inactive' and proc.alive()
        assert client.change(Transition.TRANSITION_ACTIVATE)
        client.wait_matched()
        assert client.answered(time.time_ns(), 5.0)
    finally:
        client.close()
        code = proc.stop()
    assert code == 0
    assert 'Traceback' not in proc.output()


def test_cleanup_under_a_stream_is_quiet(sweep):
    """A cleanup while setpoints keep arriving: those the node takes after it
    stopped being active are dropped quietly (counted inactive), never an
    internal error (8 cycles over the two tiers)."""
    proc, client = managed('/lcstream')
    try:
        base = time.time_ns() - 10 ** 9
        for k in range(sweep(8)):
            assert client.change(Transition.TRANSITION_CONFIGURE)
            assert client.change(Transition.TRANSITION_ACTIVATE)
            client.wait_matched()
            for i in range(1500):       # a backlog the node is still working through
                client.send(base + (k * 2000 + i) * 1_000_000, Q, QD, QDD)
            assert client.change(Transition.TRANSITION_DEACTIVATE)
            assert client.change(Transition.TRANSITION_CLEANUP)
        assert client.change(Transition.TRANSITION_CONFIGURE)
        values = client.wait_diagnostics(lambda v: 'rejected total' in v)
        assert proc.alive()
    finally:
        client.close()
        proc.stop()
    log = proc.output()
    assert 'ERROR' not in log and 'internal error' not in log, log[-3000:]
    assert int(values.get('rejected solver_error', 0)) == 0, values


@pytest.mark.parametrize('executor', ['events', 'single'])
def test_setpoints_published_while_inactive_are_not_answered_after_activation(executor):
    """100 setpoints and the activate request sent to the inactive node while it
    is stopped (SIGSTOP: a node too busy to take them, and a transport that
    holds some of them back): none of them is answered after the activation,
    all are counted inactive, and the next one is answered. (Before: the
    wait-set executor served the request before the queue and answered 99.)"""
    proc, client = managed(f'/lcq{executor}', executor=executor)
    count = 100
    try:
        assert client.change(Transition.TRANSITION_CONFIGURE)
        client.wait_matched()
        base = time.time_ns() - 10 ** 9
        os.kill(proc.proc.pid, signal.SIGSTOP)
        try:
            for i in range(count):
                client.send(base + i * 1_000_000, Q, QD, QDD)
            future = client.srv['change_state'].call_async(ChangeState.Request(
                transition=Transition(id=Transition.TRANSITION_ACTIVATE)))
            client.spin_until(lambda: False, 0.3)     # the request is out
        finally:
            os.kill(proc.proc.pid, signal.SIGCONT)
        assert client.spin_until(future.done, 20.0) and future.result().success
        fresh = time.time_ns()
        assert client.answered(fresh, 10.0)
        values = client.wait_diagnostics(
            lambda v: int(v.get('received pose', 0)) >= count + 1)
    finally:
        client.close()
        proc.stop()
    stale = [stamp_ns(m) for _, m in client.actuator if stamp_ns(m) < fresh]
    assert stale == []
    assert int(values['rejected inactive']) == 3 * count, values
