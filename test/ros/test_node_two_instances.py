"""Two instances under one diagnostics monitor (issue 15 #1): a node in the
root namespace and one in /sim publish two /diagnostics entries, each named
by the node's fully qualified name and carrying the hardware_id of its own
``diagnostics.hardware_id`` parameter, so an aggregator keeps them apart.
Before the fix both were named ``flight_sim_dynamics`` with one hardware_id
and merged into one flickering entry.
"""
from __future__ import annotations

import pytest

from flight_sim_dynamics.ros.diagnostics import diagnostic_name
from node_harness import NODE_NAME, Client, NodeProcess

pytestmark = pytest.mark.ros


def test_two_namespaced_instances_are_two_diagnostic_entries():
    nodes = {'/': NodeProcess('-p', 'diagnostics.period:=0.25',
                              '-p', 'diagnostics.hardware_id:=rig_root'),
             '/sim': NodeProcess('-r', '__ns:=/sim', '-p', 'diagnostics.period:=0.25',
                                 '-p', 'diagnostics.hardware_id:=rig_sim')}
    client = Client()
    try:
        names = {diagnostic_name(f'{ns.rstrip("/")}/{NODE_NAME}'): ns for ns in nodes}
        seen: dict[str, str] = {}

        def both_seen() -> bool:
            for msg in client.diagnostics:
                for status in msg.status:
                    if status.name in names:
                        seen[status.name] = status.hardware_id
            for node in nodes.values():
                assert node.alive(), node.output()[-3000:]
            return len(seen) == len(names)

        assert client.spin_until(both_seen, 20.0), f'entries seen: {seen}'
        assert seen == {diagnostic_name(f'/{NODE_NAME}'): 'rig_root',
                        diagnostic_name(f'/sim/{NODE_NAME}'): 'rig_sim'}
        # and nothing else of ours under the bare node name
        bare = {s.name for m in client.diagnostics for s in m.status}
        assert NODE_NAME not in bare
    finally:
        client.close()
        for node in nodes.values():
            node.stop()
