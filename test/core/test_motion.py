"""core/motion.py's PlannerSequence over each machine's planner motions
(Machine.planner_motions, planner_example): every sample of the machine's
size, continuous, from rest at home to rest at home.
"""
from __future__ import annotations

import numpy as np
import pytest

from flight_sim_dynamics.core.motion import PlannerSequence
from flight_sim_dynamics.machines import MACHINES


@pytest.mark.parametrize('machine', MACHINES, ids=lambda m: m.name)
def test_every_machine_plays_its_planner_motions(machine):
    assert machine.planner_example in machine.planner_motions
    assert set(machine.planner_motions) <= set(machine.motions)
    sequence = PlannerSequence(machine.motions, list(machine.planner_motions))
    t = np.arange(0.0, sequence.period, 0.005)
    q = np.array([sequence.sample(x)[0] for x in t])
    assert q.shape == (len(t), machine.dof)
    assert np.abs(np.diff(q, axis=0)).max() < 5e-3            # no jumps
    assert np.abs(q[0]).max() < 1e-12 and np.abs(sequence.sample(sequence.period)[0]).max() < 1e-9
    assert sequence.finished(sequence.period + 0.01)


def test_an_unknown_motion_is_refused_naming_the_choices():
    three, six = MACHINES
    with pytest.raises(ValueError, match='cueing'):
        PlannerSequence(six.motions, ['general'])
