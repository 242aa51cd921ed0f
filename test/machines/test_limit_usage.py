"""One limit rule: for every registered machine, a solution that is otherwise
ok has the status ``limit`` exactly when its ``limit_usage`` exceeds 1
somewhere, through the compiled kernel (its transcription of the rule) and
the Python code alike, one sample or a batch.
"""
from __future__ import annotations

import dataclasses
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flight_sim_dynamics as fsd
from flight_sim_dynamics.core import kernel as core_kernel
from flight_sim_dynamics.core.machine import LimitUsage
from flight_sim_dynamics.core.status import Status
from flight_sim_dynamics.machines import MACHINES

#: Each machine's limit parameters by the kind of usage they bound (a stroke's:
#: its two ends), and the joint-angle limits it has that are off by default,
#: set here where motions about home do not reach them.
LIMIT_FIELDS = {
    'flight_simulator_3dof': {'stroke': ('stroke_min', 'stroke_max'), 'speed': 'max_speed',
                              'force': 'max_force'},
    'stewart': {'stroke': ('length_min', 'length_max'), 'speed': 'max_speed',
                'force': 'max_force', 'u_joint': 'u_joint_max_angle',
                'spherical': 'spherical_joint_max_angle'},
}
LOOSE = {'stewart': dict(u_joint_max_angle=1.0, spherical_joint_max_angle=1.0)}
JUDGED = (Status.OK, Status.LIMIT)          # the statuses the limit rule decides between


def _model(machine, **limits):
    model = fsd.load_model(machine.parameter_files[0] if machine.parameter_files else None)
    if limits:
        model = dataclasses.replace(model, limits=dataclasses.replace(model.limits, **limits))
    return model


def _crossed(machine, loose, usage, kind):
    """``loose`` with its limit of ``kind`` scaled to what the median sample
    uses, so that about half the samples exceed it (a stroke: its range about
    its middle).
    """
    columns = [k for k, name in enumerate(usage.names) if name.split()[0] == kind]
    median = float(np.median(usage.usage[:, columns].max(axis=1)))
    field = LIMIT_FIELDS[machine.name][kind]
    if isinstance(field, tuple):
        low, high = (getattr(loose.limits, f) for f in field)
        middle = 0.5 * (low + high)
        change = {field[0]: middle - (middle - low) * median,
                  field[1]: middle + (high - middle) * median}
    else:
        change = {field: getattr(loose.limits, field) * median}
    return dataclasses.replace(loose, limits=dataclasses.replace(loose.limits, **change))


def _scales(machine, motion):
    """Random motions about home: per coordinate (m or rad) pose, rate, acceleration."""
    return np.array([{'pose': 0.06, 'rate': 0.4, 'acceleration': 6.0}[motion]] * machine.dof)


def _samples(machine, n, seed):
    rng = np.random.default_rng(seed)
    return tuple(rng.uniform(-1.0, 1.0, (n, machine.dof)) * _scales(machine, motion)
                 for motion in ('pose', 'rate', 'acceleration'))


def _check(machine, model, status, usage: LimitUsage) -> None:
    """status limit <=> some usage > 1, for a solution that the rule judges."""
    if status in JUDGED:
        assert (status is Status.LIMIT) == (usage.usage.max() > 1.0), (
            machine.name, status, model.limits, dict(zip(usage.names, usage.usage.tolist())))


MACHINE_IDS = [m.name for m in MACHINES]


def _judge_batch(machine, model, q, qd, qdd) -> dict:
    """The batch's and some single solves' statuses against their usages;
    the count of each status.
    """
    batch = machine.solve_batch(model, q, qd, qdd)
    usage = machine.limit_usage(model, batch)
    assert usage.usage.shape == (len(q), len(usage.names))
    np.testing.assert_array_equal(usage.exceeded, (usage.usage > 1.0).any(axis=1))
    for i, status in enumerate(batch.status):
        _check(machine, model, batch.status[i], LimitUsage(usage.names, usage.usage[i]))
    for i in range(0, len(q), 10):
        sol = machine.solve(model, q[i], qd[i], qdd[i])
        single = machine.limit_usage(model, sol)
        assert single.names == usage.names and sol.status is batch.status[i]
        np.testing.assert_allclose(single.usage, usage.usage[i], rtol=1e-12, atol=1e-15)
        _check(machine, model, sol.status, single)
    return {s: int(np.sum(batch.status == s)) for s in JUDGED}


@pytest.mark.parametrize('kernel', [True, False], ids=['kernel', 'python'])
@pytest.mark.parametrize('machine', MACHINES, ids=MACHINE_IDS)
def test_status_limit_is_usage_above_one(machine, kernel):
    """Random motions about home, on the packaged limits (with every optional
    limit set) and with each kind of limit in turn tightened so that about
    half of them cross it: each judged sample's status follows its usages, as
    a batch and one by one, through the kernel and the Python code.
    """
    loose = _model(machine, **LOOSE.get(machine.name, {}))
    q, qd, qdd = _samples(machine, 300, seed=machine.dof)
    with core_kernel.use_kernel(kernel):
        _judge_batch(machine, loose, q, qd, qdd)
        usage = machine.limit_usage(loose, machine.solve_batch(loose, q, qd, qdd))
        for kind in LIMIT_FIELDS.get(machine.name, {}):
            seen = _judge_batch(machine, _crossed(machine, loose, usage, kind), q, qd, qdd)
            assert min(seen.values()) >= 60, (kind, seen)      # both, about half each


@pytest.mark.parametrize('kernel', [True, False], ids=['kernel', 'python'])
@pytest.mark.parametrize('machine', MACHINES, ids=MACHINE_IDS)
def test_limit_crossing_samples(machine, kernel):
    """A sample's speed or force limit set just above and just below what it
    uses (1e-9 relative): the status changes with the usage's side of 1.
    """
    base = _model(machine)

    @settings(max_examples=40, deadline=None)
    @given(pose=st.lists(st.floats(-1.0, 1.0), min_size=machine.dof, max_size=machine.dof),
           rate=st.lists(st.floats(-1.0, 1.0), min_size=machine.dof, max_size=machine.dof),
           acceleration=st.lists(st.floats(-1.0, 1.0), min_size=machine.dof,
                                 max_size=machine.dof),
           which=st.sampled_from(['max_speed', 'max_force']),
           side=st.sampled_from([-1e-9, 1e-9]))
    def check(pose, rate, acceleration, which, side):
        q, qd, qdd = (np.array(v) * _scales(machine, m) for v, m in
                      ((pose, 'pose'), (rate, 'rate'), (acceleration, 'acceleration')))
        with core_kernel.use_kernel(kernel):
            sol = machine.solve(base, q, qd, qdd)
            if sol.status not in JUDGED:
                return
            used = float(np.abs(sol.rate if which == 'max_speed' else sol.force).max())
            if not used > 0.0:
                return
            model = _model(machine, **{which: used * (1.0 + side)})
            crossed = machine.solve(model, q, qd, qdd)
            usage = machine.limit_usage(model, crossed)
            _check(machine, model, crossed.status, usage)
            if side < 0:            # beyond the limit it crossed, whatever the others
                assert crossed.status is Status.LIMIT or crossed.status not in JUDGED
                assert usage.exceeded
            batch = machine.solve_batch(model, q[None], qd[None], qdd[None])
            assert batch.status[0] is crossed.status
            np.testing.assert_array_equal(machine.limit_usage(model, batch).exceeded,
                                          [usage.exceeded])
    check()


@pytest.mark.parametrize('machine', MACHINES, ids=MACHINE_IDS)
def test_usage_names_and_values_at_home(machine):
    """Every leg has a stroke, speed and force usage, named with its label; at
    rest at home no speed is used and nothing is exceeded on the packaged
    limits; an empty batch has no usages.
    """
    model = _model(machine)
    z = [0.0] * machine.dof
    usage = machine.limit_usage(model, machine.solve(model, z, z, z))
    for label in machine.leg_labels:
        for kind in ('stroke', 'speed', 'force'):
            assert f'{kind} {label.upper()}' in usage.names
    speeds = [u for name, u in zip(usage.names, usage.usage) if name.startswith('speed')]
    assert speeds == [0.0] * len(machine.legs)
    assert not usage.exceeded and np.all(usage.usage >= 0.0)
    assert np.all(np.isfinite(usage.usage))
    empty = np.zeros((0, machine.dof))
    none = machine.limit_usage(model, machine.solve_batch(model, empty, empty, empty))
    assert none.usage.shape == (0, len(usage.names)) and none.exceeded.shape == (0,)
