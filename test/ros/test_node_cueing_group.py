"""The dynamics node on a params file with a cueing group (the motion-cueing
node's, config/stewart_6dof.yaml): it starts, answers, and does not take the
group for typos."""
from __future__ import annotations

import itertools

import pytest

from node_harness import ROOT, Client, NodeProcess

pytestmark = pytest.mark.ros


def test_the_node_starts_on_a_file_with_a_cueing_group_and_ignores_it_quietly():
    proc = NodeProcess(params_file=ROOT / 'config' / 'stewart_6dof.yaml')
    c = Client('cueing_group_client')
    try:
        c.wait_for_node(proc)
        # answered (discovery both ways: a lone first setpoint can be lost before it)
        stamps = itertools.count(1_600_000_000 * 1_000_000_000, 10_000_000)
        c.round_trip(lambda: next(stamps))
        assert 'cueing' in (ROOT / 'config' / 'stewart_6dof.yaml').read_text()
        assert 'cueing.' not in proc.output()
    finally:
        c.close()
        assert proc.stop() == 0
