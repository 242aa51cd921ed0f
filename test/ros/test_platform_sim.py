"""The twin node ``platform_sim`` as a separate process over DDS, fed by the
real ``dynamics_node`` (one remap: ``actuator_commands:=actuator_states``).

* tracking: the paper's general motion streamed as setpoints at 100 Hz into
  dynamics_node; its actuator_states drive the twin; the simulated pose
  follows the commanded one (each coordinate's RMS error, at the delay that
  fits best, a small part of its motion's RMS);
* bad commands on actuator_commands are rejected, counted by reason, and
  nothing non-finite is published; the node survives garbage;
* commands far beyond the plant's limits are rejected and the held one stays;
* leg lengths far out of reach stop the plant with an ERROR status in
  /diagnostics; it holds its last state, finite; ``~/reset`` runs it again;
* a burst of commands at several kHz leaves the loop at its tick rate; what
  is superseded or undecodable is counted.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.schema import SIM_PARAMETERS
from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.machines.staicu.model import LEG_NAMES
from flight_sim_dynamics.machines.staicu.motions import MOTIONS
from flight_sim_dynamics.ros.process import SIM_MODULE, stop_node
from flight_sim_dynamics.ros.messages import NON_FINITE, quaternion_to_rpy
from node_harness import PARAMS_FILE, QOS, ROOT, Client
from sim_harness import (SimClient, command, node_and_twin, own_twin, sim_output, stamp,
                         start_sim, stream, tracking_errors)

pytestmark = pytest.mark.ros

RATE = 100.0


@pytest.fixture
def strong(tmp_path) -> Path:
    """The packaged 3-DOF machine with actuators strong and fast enough to
    drive the plant out of its workspace (the twin's stop)."""
    path = tmp_path / 'strong.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    limits:\n'
                    '      max_force: 1000000.0\n      max_speed: 100.0\n')
    return path


@pytest.fixture(scope='module')
def pipeline():
    with node_and_twin('twin_test_client') as running:
        yield running


def test_twin_waits_at_rest_before_the_first_command():
    sim, log = start_sim(namespace='/idle')
    client = Client('twin_idle_client')
    try:
        twin = SimClient(client, '/idle')
        ok = client.spin_until(lambda: twin.ready() or sim.poll() is not None, 20.0)
        assert ok and sim.poll() is None, sim_output(log)[-3000:]
        values = twin.diagnostics(lambda v: True)
        assert values['message'] == 'waiting for commands'
        assert values['commands received'] == '0'
        assert client.spin_until(lambda: len(twin.poses) > 3, 5.0)
        assert all(abs(m.pose.position.x) + abs(m.pose.position.z) == 0.0
                   for m in twin.poses)
    finally:
        client.close()
        stop_node(sim)
        log.close()
        Path(log.name).unlink(missing_ok=True)


@pytest.mark.real_time
def test_simulated_pose_follows_the_commanded_one(pipeline):
    client, twin, sim, _ = pipeline
    sequence = PlannerSequence(MOTIONS, ['general'])
    n = int(sequence.period * RATE) + 1
    first_pose, first = len(twin.poses), len(client.actuator)
    # paced in real time (the twin runs in real time)
    t0, sent = stream(client, n, RATE,
                      lambda k, at: client.send(at, *sequence.sample(k / RATE)[:3]))
    assert client.wait_actuator(first + n, 10.0), \
        f'{len(client.actuator) - first} of {n} answered' + client.explain()
    end = t0 + round((n - 1) * 1e9 / RATE)
    assert client.spin_until(lambda: twin.poses and stamp(twin.poses[-1]) > end, 5.0)
    tick_rate = next(s.default for s in SIM_PARAMETERS if s.name == 'tick_rate')

    def coordinates(m) -> list[float]:
        """Surge, heave, roll of a platform_pose."""
        o = m.pose.orientation
        return [m.pose.position.x, m.pose.position.z, quaternion_to_rpy(o.x, o.y, o.z, o.w)[0]]
    peak, ratio, count = tracking_errors(twin.poses[first_pose:], sequence, t0, sent, RATE,
                                         coordinates)
    print(f'twin tracking over {count} poses: max error surge, heave, roll {peak.round(4)}, '
          f'RMS error / RMS motion {ratio.round(3)}')
    assert count > 0.5 * sequence.period * tick_rate     # one pose per tick
    # at the delay that fits best (a busy host delivers the commands late, up to
    # 0.3 s; offline, commands held at 100 Hz: roll 1.4e-3 rad at its peak): a
    # twin that does not move scores 1, one with a coordinate of the wrong sign 2
    assert ratio.max() < 0.25
    values = twin.diagnostics(lambda v: int(v['commands accepted']) >= n)
    assert values['rejected total'] == '0'
    assert values['outcome'] == 'ok' and values['status'] in ('OK', 'WARN')
    assert float(values['real-time factor']) > 0.5
    assert twin.all_finite()
    # measured lengths: the plant's own at the simulated pose
    model = fsd.load_model(PARAMS_FILE)
    m, p = twin.measured[-1], twin.poses[-1]
    roll = quaternion_to_rpy(p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z,
                             p.pose.orientation.w)[0]
    if stamp(m) == stamp(p):
        expected = fsd.solve(model, [p.pose.position.x, p.pose.position.z, roll],
                             [0, 0, 0], [0, 0, 0]).length
        np.testing.assert_allclose(list(m.position), expected, atol=1e-9)
    assert tuple(m.name) == LEG_NAMES


def test_bad_commands_are_counted_and_nothing_non_finite_is_published(pipeline):
    client, twin, sim, _ = pipeline
    pub = client.node.create_publisher(JointState, 'actuator_states', QOS)
    assert client.spin_until(lambda: pub.get_subscription_count() >= 2, 5.0)
    # its own last accepted command (whatever an earlier test left): hold the
    # central pose, stamped now (after every command an earlier test sent)
    rest = fsd.solve(fsd.load_model(PARAMS_FILE), [0, 0, 0], [0, 0, 0], [0, 0, 0])
    latest = client.node.get_clock().now().nanoseconds
    accepted = int(twin.diagnostics(lambda v: True)['commands accepted'])
    pub.publish(command(latest, position=rest.length, effort=rest.force))
    before = twin.diagnostics(lambda v: int(v['commands accepted']) > accepted)
    old = 1_000_000_000          # long before every stamp the twin has accepted
    nan, inf = float('nan'), float('inf')
    bad = {
        'bad_names': [command(old, names=LEG_NAMES[:2]), command(old, names=('A', 'B', 'C')),
                      command(old, names=LEG_NAMES[:2] + LEG_NAMES[:1]),
                      command(old, names=())],
        'bad_size': [command(old, position=(1.0, 1.0)), command(old, velocity=(0.0,) * 4),
                     command(old, effort=(1.0,))],
        'non_finite': [command(old, position=(nan, 1.0, 1.0)),
                       command(old, velocity=(0.0, inf, 0.0)),
                       command(old, effort=(0.0, 0.0, -inf))],
    }
    for msgs in bad.values():
        for msg in msgs:
            pub.publish(msg)
    # two stamps before the last accepted one (fewer than a restart's three)
    pub.publish(command(latest - 10**8))
    pub.publish(command(latest - 10**8))

    def counted(v: dict[str, str]) -> bool:
        return all(int(v[f'rejected {reason}']) - int(before[f'rejected {reason}'])
                   >= len(msgs) for reason, msgs in bad.items()) and \
            int(v['rejected stamp_backwards']) + int(v['rejected stamp_repeated']) \
            - int(before['rejected stamp_backwards']) - int(before['rejected stamp_repeated']) >= 2
    values = twin.diagnostics(counted)
    assert values['commands accepted'] == before['commands accepted']
    assert values['level'] == '1' and 'rejected' in values['message']
    assert values['outcome'] == 'ok'
    # garbage in every field: the node carries on
    rng = np.random.default_rng(7)
    for k in range(200):
        size = int(rng.integers(0, 5))
        values_ = rng.choice([nan, inf, -inf, 1e308, -1e308, 0.0, 1.0], size=(3, size))
        names = [str(x) for x in rng.choice([*LEG_NAMES, '', 'é', 'A' * 300], size=size)]
        pub.publish(command(int(rng.integers(0, 2**62)), names=names, position=values_[0],
                            velocity=values_[1], effort=values_[2]))
    after = twin.diagnostics(lambda v: int(v['commands received'])
                             >= int(before['commands received']) + 212)
    assert sim.poll() is None
    assert int(after['rejected total']) > int(before['rejected total'])
    count = len(twin.poses)
    assert client.spin_until(lambda: len(twin.poses) > count + 10, 5.0), 'twin stopped publishing'
    assert twin.all_finite()


def test_out_of_reach_command_stops_the_plant_and_a_reset_runs_it_again(strong):
    """Leg lengths 1 m beyond the central ones: the servos drive the plant out
    of its workspace (limits raised so the actuators can); it stops, ERROR,
    and keeps publishing its held state, finite. ``~/reset`` puts it back at
    rest at ``initial``, waiting for a command, and the next one runs it.
    """
    with own_twin('/lost', '-p', f'plant.params_file:={strong}') as (client, twin, pub, sim):
        model = fsd.load_model()
        rest = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0])
        t0 = client.node.get_clock().now().nanoseconds
        pub.publish(command(t0, position=rest.length + np.array([1.0, -1.0, 1.0]),
                            effort=rest.force))
        values = twin.diagnostics(lambda v: v['status'] == 'ERROR')
        assert values['message'].startswith('stopped: ')
        assert values['outcome'].split(':')[0] in ('unreachable', 'near_singular')
        count = len(twin.poses)
        assert client.spin_until(lambda: len(twin.poses) > count + 5, 5.0)
        assert twin.all_finite()
        assert sim.poll() is None

        client.srv['reset'] = client.node.create_client(Trigger, '/lost/platform_sim/reset')
        response = client.call('reset', Trigger.Request(), timeout=10.0)
        assert response.success, response.message
        values = twin.diagnostics(lambda v: v['message'] == 'waiting for commands')
        assert values['outcome'] == 'ok' and values['status'] == 'OK'
        count = len(twin.poses)
        assert client.spin_until(lambda: len(twin.poses) > count + 3, 5.0)
        assert all(m.pose.position.x == m.pose.position.z == m.pose.orientation.x == 0.0
                   for m in twin.poses[count:])
        # runs again (an earlier stamp than before the reset: the order is forgotten)
        pub.publish(command(t0 - 10**9, position=rest.length, effort=rest.force))
        values = twin.diagnostics(lambda v: int(v['steps']) > 0 and v['outcome'] == 'ok')
        assert int(values['commands accepted']) == 2


def test_a_rejection_then_a_stop_then_a_rejection_leave_the_twin_up_logging_each(strong):
    """A rejected command (NaN: WARN), then commands that drive the plant out of
    its workspace (the stop: ERROR), then another rejected one (WARN after the
    ERROR): the twin stays up, logs each line at its severity (/rosout),
    reports the stop on /diagnostics and a ``~/reset`` runs it again.
    """
    with own_twin('/warned', '-p', f'plant.params_file:={strong}') as (client, twin, pub, sim):
        lines: list[Log] = []
        rosout = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                            reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
        client.node.create_subscription(Log, '/rosout', lambda m: lines.append(m)
                                        if m.name == 'warned.platform_sim' else None, rosout)

        def logged(level: int, text: str) -> bool:
            return any(m.level == level and text in m.msg for m in lines)
        assert client.spin_until(lambda: bool(lines), 10.0), 'no /rosout line of the twin'
        rest = fsd.solve(fsd.load_model(), [0, 0, 0], [0, 0, 0], [0, 0, 0])
        t0 = client.node.get_clock().now().nanoseconds
        pub.publish(command(t0, position=rest.length, effort=rest.force))
        pub.publish(command(t0 + 1, position=(float('nan'), 1.0, 1.0)))
        assert client.spin_until(lambda: logged(Log.WARN, NON_FINITE), 10.0)
        pub.publish(command(t0 + 2, position=rest.length + np.array([1.0, -1.0, 1.0]),
                            effort=rest.force))
        values = twin.diagnostics(lambda v: v['status'] == 'ERROR')
        assert values['message'].startswith('stopped: ')
        assert int(values['rejected non_finite']) == 1
        pub.publish(command(t0 + 3, position=(1.0, 1.0)))
        twin.diagnostics(lambda v: int(v['rejected bad_size']) == 1)
        assert client.spin_until(lambda: logged(Log.ERROR, 'stopped: ')
                                 and logged(Log.WARN, 'bad_size'), 10.0), \
            [(m.level, m.msg) for m in lines]
        assert sim.poll() is None
        assert not logged(Log.ERROR, 'internal error')

        client.srv['reset'] = client.node.create_client(Trigger, '/warned/platform_sim/reset')
        response = client.call('reset', Trigger.Request(), timeout=10.0)
        assert response.success, response.message
        twin.diagnostics(lambda v: v['message'] == 'waiting for commands')
        pub.publish(command(t0 + 4, position=rest.length, effort=rest.force))
        values = twin.diagnostics(lambda v: int(v['steps']) > 0 and v['outcome'] == 'ok')
        assert sim.poll() is None


def test_commands_far_beyond_the_limits_are_rejected_and_the_held_one_stays():
    """Force, rate or stroke far beyond what the machine can do (a fault
    upstream): rejected, counted ``beyond_limits``; the held command keeps
    the plant at rest, running."""
    with own_twin('/far') as (client, twin, pub, sim):
        model = fsd.load_model()
        lim = model.limits
        rest = fsd.solve(model, [0, 0, 0], [0, 0, 0], [0, 0, 0])
        t0 = client.node.get_clock().now().nanoseconds
        pub.publish(command(t0, position=rest.length, effort=rest.force))
        span = lim.stroke_max - lim.stroke_min
        high = model.geometry.L0 + lim.stroke_max + 1.01 * span
        low = model.geometry.L0 + lim.stroke_min - 1.01 * span
        far = [command(t0 + 1, position=rest.length, effort=(1e300, 0.0, 0.0)),
               command(t0 + 2, position=rest.length, effort=(0.0, -10.1 * lim.max_force, 0.0)),
               command(t0 + 3, position=rest.length, velocity=(0.0, 0.0, 10.1 * lim.max_speed)),
               command(t0 + 4, position=(high[0], rest.length[1], rest.length[2])),
               command(t0 + 5, position=(rest.length[0], low[1], rest.length[2])),
               command(t0 + 6, position=(1e300, 1.0, 1.0))]
        for msg in far:
            pub.publish(msg)
        values = twin.diagnostics(lambda v: int(v.get('rejected beyond_limits', 0)) >= len(far))
        assert values['commands accepted'] == '1' and values['status'] == 'WARN'
        count = len(twin.poses)
        assert client.spin_until(lambda: len(twin.poses) > count + 50, 10.0)
        values = twin.diagnostics(lambda v: True)
        assert values['outcome'] == 'ok' and sim.poll() is None
        assert max(abs(m.pose.position.x) + abs(m.pose.position.z) for m in twin.poses) < 1e-3


#: The burst: commands, and the most sent per second (paced; one Python
#: publisher on the shared host reaches 25-35 kHz). Seen: the twin's poses at
#: 117-154 Hz during it on a quiet host, 9 Hz beside the rest of the test
#: tiers; 8-36 Hz when a command cost the loop a step (a callback that
#: simulated each one): how fast it ticks under load is not the test's.
BURST, BURST_RATE = 20000, 40000.0


def test_a_command_burst_leaves_the_loop_at_its_rate():
    """A few thousand commands at several kHz: the twin keeps publishing its
    state through the burst and at its tick rate after it; a tick uses the
    latest command, the others are superseded (counted in /diagnostics, a
    number no load changes: a loop that simulated each command supersedes
    none), and undecodable messages are counted."""
    with own_twin('/burst') as (client, twin, pub, sim):
        stamps: list[int] = []        # the twin's own times, not when the client got them
        client.node.create_subscription(PoseStamped, '/burst/platform_pose',
                                        lambda m: stamps.append(stamp(m)), QOS)
        now = client.node.get_clock().now
        rest = fsd.solve(fsd.load_model(), [0, 0, 0], [0, 0, 0], [0, 0, 0])
        t0 = client.node.get_clock().now().nanoseconds
        msgs = [command(t0 + k * 10**5, position=rest.length, effort=rest.force)
                for k in range(BURST)]
        garbage = [b'\x00\x01\x00\x00' + b'\xff' * (8 + k) for k in range(BURST // 100)]
        start, wall = now().nanoseconds, time.monotonic()

        def burst() -> None:
            for k, msg in enumerate(msgs):
                pub.publish(msg)
                if k % 100 == 0:
                    pub.publish(garbage[k // 100])     # raw bytes that decode to nothing
                if k % 10 == 0:
                    time.sleep(max(0.0, wall + k / BURST_RATE - time.monotonic()))
        thread = threading.Thread(target=burst)
        thread.start()
        client.spin_until(lambda: not thread.is_alive(), 120.0)
        thread.join()
        end = now().nanoseconds
        # the poses stamped up to 2 s after the burst, however late the client reads them
        client.spin_until(lambda: bool(stamps) and max(stamps) > end + 2_000_000_000, 10.0)
        during = sum(start <= t <= end for t in stamps) / ((end - start) * 1e-9)
        after = sum(end < t <= end + 2_000_000_000 for t in stamps) / 2.0
        print(f'burst of {BURST} in {(end - start) * 1e-9:.2f} s; twin poses at {during:.0f} Hz '
              f'during it, {after:.0f} Hz in the 2 s after')
        tick_rate = next(s.default for s in SIM_PARAMETERS if s.name == 'tick_rate')
        # it keeps ticking through the burst: poses in both halves of it (how many
        # depends on what else the shared host runs; a loop that worked through
        # the queue before ticking has none in the second half), and it is at
        # its rate right after it (the queued commands are not worked through)
        middle = (start + end) // 2
        assert any(start <= t <= middle for t in stamps)
        assert any(middle < t <= end for t in stamps)
        assert after > tick_rate / 2
        values = twin.diagnostics(lambda v: int(v.get('rejected undecodable', 0)) >= 1)
        print({k: values[k] for k in ('commands received', 'commands accepted',
                                      'commands superseded', 'rejected undecodable')})
        assert 0 < int(values['commands superseded']) < int(values['commands accepted'])
        assert int(values['rejected total']) == int(values['rejected undecodable'])
        assert values['outcome'] == 'ok' and sim.poll() is None


def test_bad_parameters_refuse_to_start():
    sim, log = start_sim('-p', 'plant.scene:=quasi_static', namespace='/bad')
    try:
        assert sim.wait(30) == 2
        assert 'computes no inertia' in sim_output(log)
    finally:
        stop_node(sim)
        log.close()
        Path(log.name).unlink(missing_ok=True)


def test_sim_help():
    out = subprocess.run([sys.executable, '-m', SIM_MODULE, '--help'], cwd=ROOT,
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert 'actuator_commands' in out.stdout


def test_demo_with_the_twin_plots_commanded_against_simulated(tmp_path):
    png = tmp_path / 'demo.png'
    # A ROS domain of its own: the module's node (same name) is still running,
    # and the demo's node would refuse to start next to it.
    env = dict(os.environ, ROS_DOMAIN_ID=str((int(os.environ['ROS_DOMAIN_ID']) + 50) % 100 + 1))
    out = subprocess.run([sys.executable, '-m', 'flight_sim_dynamics.cli.demo', '-o', str(png),
                          '--motions', 'vertical', '--rate', '100', '--twin'],
                         cwd=ROOT, capture_output=True, text=True, timeout=90, env=env)
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / 'demo_twin.png').stat().st_size > 10_000
    line = next(line for line in out.stdout.splitlines() if line.startswith('[demo] twin: '))
    assert 'twin poses; tracking error max / RMS' in line
    sent, received, missing = map(int, re.search(
        r'sent (\d+) setpoints, received (\d+) actuator_states \((\d+) missing\)',
        out.stdout).groups())
    assert sent == received == 301 and missing == 0, out.stdout[-2000:]
