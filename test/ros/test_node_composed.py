"""Two dynamics nodes composed in one process (namespaces /c1 and /c2, each
with its own parameters): each answers its own setpoints with its own model;
nothing of the node depends on the process's command line."""
from __future__ import annotations

import itertools
import subprocess
import sys
import tempfile
import textwrap

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.config.node_schema import node_schema
from flight_sim_dynamics.machines.staicu.trajectories import paper_example
from flight_sim_dynamics.ros.process import node_env
from node_harness import ROOT, Client, NodeProcess, stamp_ns

pytestmark = pytest.mark.ros

Q, QD, QDD = (v[0] for v in paper_example('general', np.array([0.8])))
MASSES = {'/c1': 5.0, '/c2': 9.0}
SCRIPT = textwrap.dedent(f'''
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from flight_sim_dynamics.ros.dynamics_node import DynamicsNode
    from flight_sim_dynamics.ros.node import running, spin
    with running('composed', []) as nodes:
        executor = SingleThreadedExecutor()
        for namespace, mass in {MASSES!r}.items():
            node = DynamicsNode(namespace=namespace, parameter_overrides=[
                Parameter('bodies.platform.mass', value=mass)])
            nodes.append(node)
            assert node.start(), node.failure
            executor.add_node(node)
        spin(executor)
''')


class ComposedProcess(NodeProcess):
    """The two nodes in one ``python -c`` process."""

    def __init__(self) -> None:      # noqa: D107 - NodeProcess's, another command
        self.cmd = [sys.executable, '-c', SCRIPT, '--params-file', 'no_such_file.yaml']
        self.log = tempfile.NamedTemporaryFile('w+', prefix='fsd_composed_', suffix='.log',
                                               delete=False)
        self._final_output = None
        self.proc = subprocess.Popen(self.cmd, stdout=self.log, stderr=subprocess.STDOUT,
                                     env=node_env(), cwd=ROOT, start_new_session=True)


def test_two_nodes_in_one_process_answer_each_with_its_own_model():
    proc = ComposedProcess()
    clients = {ns: Client(f'composed_client{ns.replace("/", "_")}', namespace=ns)
               for ns in MASSES}
    try:
        for namespace, client in clients.items():
            client.wait_for_node(proc)
            client.round_trip(itertools.count(1_600_000_000 * 1_000_000_000, 5_000_000).__next__)
        for k, (namespace, client) in enumerate(clients.items()):
            values = prm.defaults()
            values['bodies.platform.mass'] = MASSES[namespace]
            expected = fsd.solve(node_schema().model(values), Q, QD, QDD).force
            n = len(client.actuator)
            stamp = 1_700_000_000 * 1_000_000_000 + k
            client.send(stamp, Q, QD, QDD)
            assert client.wait_actuator(n + 1), proc.output()[-3000:]
            msg = client.actuator[n][1]
            assert stamp_ns(msg) == stamp
            np.testing.assert_allclose(msg.effort, expected, rtol=0, atol=1e-9)
        assert proc.alive()
    finally:
        for client in clients.values():
            client.close()
        proc.stop()
    assert 'Traceback' not in proc.output()
