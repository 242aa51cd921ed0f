"""The planner (flight_sim_dynamics/cueing/planner.py): the washout in a
machine's coordinates, channels it lacks dropped and reported; streaming and
batch one loop (bit for bit), its washout in a second process too; the input
resampled (repeated times dropped and counted, a time going backwards named by
its sample)."""
from __future__ import annotations

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.config.cueing import G, defaults
from flight_sim_dynamics.config.machine_files import load_cueing
from flight_sim_dynamics.cueing.planner import BLOCK, INPUT_HELD, OK, Planner, resample, run
from flight_sim_dynamics.cueing.washout import Washout

NONE = defaults().replace(limiter='none')


@pytest.fixture(scope='module')
def models():
    return {'3dof': fsd.load_model(), 'hexapod': fsd.load_model('config/stewart_6dof.yaml')}


def vehicle(n=3000, rate=1000.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    knots = np.linspace(0, t[-1], 12)
    f = np.column_stack([np.interp(t, knots, rng.normal(0, 1.5, 12)) for _ in range(3)])
    f[:, 2] += G
    omega = np.column_stack([np.interp(t, knots, rng.normal(0, 0.2, 12)) for _ in range(3)])
    return t, f, omega


@pytest.mark.parametrize('name, dropped', [('3dof', ('sway', 'pitch', 'yaw')), ('hexapod', ())])
def test_the_machine_gets_its_channels_of_the_washout_and_the_others_are_reported(
        models, name, dropped):
    model = models[name]
    planner = Planner(model, NONE)
    assert planner.dropped == dropped
    coordinates = fsd.machine_of(model).coordinates
    washout = Washout(NONE)
    t, f, omega = vehicle()
    channels = ('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')
    idx = [channels.index(c) for c in coordinates]
    for k in range(len(t)):
        sample, wish = planner.step(f[k], omega[k]), washout.step(f[k], omega[k])
        assert sample.status == OK and sample.given_up == 0.0 and sample.limit == ''
        for got, want in ((sample.q, wish.q), (sample.qd, wish.qd), (sample.qdd, wish.qdd)):
            assert np.array_equal(got, want[idx])


@pytest.mark.parametrize('name', ['3dof', 'hexapod'])
def test_streaming_equals_batch_bit_for_bit(models, name):
    model = models[name]
    t, f, omega = vehicle()
    batch = run(model, NONE, t, f, omega)
    planner = Planner(model, NONE)
    stream = [planner.step(f[k], omega[k]) for k in range(len(t))]
    assert np.array_equal(batch.t, t)
    assert np.array_equal(batch.q, np.array([s.q for s in stream]))
    assert np.array_equal(batch.qd, np.array([s.qd for s in stream]))
    assert np.array_equal(batch.qdd, np.array([s.qdd for s in stream]))
    assert batch.dropped == planner.dropped and batch.repeated == 0 and batch.held == 0


@pytest.mark.parametrize('name, scale', [('3dof', 1.0), ('3dof', 4.0), ('hexapod', 4.0)])
def test_a_limited_run_is_its_planners_steps_bit_for_bit(models, name, scale):
    """run with the limiter (each block's wishes judged at once) gives
    Planner.step's samples; on the 3-DOF machine with its file's preview, a
    log it lowers nothing of (its first pass's wishes are the run's: made
    once), with held inputs, and one the look-ahead limits (preview off).
    """
    model = models[name]
    params = load_cueing('config/stewart_6dof.yaml' if name == 'hexapod' else None)
    previewed = scale == 1.0
    if not previewed:
        params = params.replace(limiter_settings={**params.limiter_settings,
                                                  'preview.slope': 0.0})
    t, f, omega = vehicle(BLOCK + 700, seed=5)
    f[:, 0] *= scale
    f[BLOCK - 3:BLOCK + 3, 1] = np.nan
    batch = run(model, params, t, f, omega)
    planner = Planner(model, params, look_ahead=not previewed)
    stream = [planner.step(f[k], omega[k]) for k in range(len(t))]
    assert (batch.given_up.max() == 0.0) == previewed
    for field in ('q', 'qd', 'qdd', 'given_up'):
        assert np.array_equal(getattr(batch, field), np.array([getattr(s, field) for s in stream]))
    assert list(batch.limit) == [s.limit for s in stream]
    assert batch.held == planner.held == 6


def test_the_input_is_resampled_linearly_to_the_output_rate():
    t = np.array([0.0, 0.0025, 0.0025, 0.004, 0.010])
    x = np.column_stack([t * 2.0, 1.0 - t])
    grid, values, repeated = resample(t, x, 1000.0)
    assert repeated == 1
    assert np.allclose(grid, np.arange(11) / 1000.0)
    assert np.allclose(values, np.column_stack([grid * 2.0, 1.0 - grid]))


def test_a_repeated_time_keeps_its_first_sample():
    grid, values, repeated = resample(np.array([0.0, 1.0, 1.0, 2.0]),
                                      np.array([[0.0], [1.0], [5.0], [2.0]]), 1.0)
    assert repeated == 1 and np.array_equal(values[:, 0], [0.0, 1.0, 2.0])


def test_a_time_going_backwards_is_an_error_naming_its_sample():
    with pytest.raises(ValueError, match='sample 3'):
        resample(np.array([0.0, 0.1, 0.2, 0.15, 0.3]), np.zeros((5, 2)), 100.0)


def test_a_non_finite_time_is_an_error_naming_its_sample():
    with pytest.raises(ValueError, match='sample 2'):
        resample(np.array([0.0, 0.1, np.nan]), np.zeros((3, 2)), 100.0)


def test_a_non_finite_input_holds_the_last_finite_one(models):
    t, f, omega = vehicle(500)
    bad = f.copy()
    bad[200:210, 0] = np.nan
    held, held_omega = f.copy(), omega.copy()     # the whole sample is held
    held[200:210], held_omega[200:210] = f[199], omega[199]
    planner, reference = Planner(models['hexapod'], NONE), Planner(models['hexapod'], NONE)
    for k in range(len(t)):
        sample, want = planner.step(bad[k], omega[k]), reference.step(held[k], held_omega[k])
        assert sample.status == (INPUT_HELD if 200 <= k < 210 else OK)
        assert np.array_equal(sample.q, want.q)
    assert planner.held == 10


def test_reset_forgets_the_reference_and_the_motion(models):
    t, f, omega = vehicle(800)
    planner = Planner(models['3dof'], NONE)
    first = [planner.step(f[k], omega[k]).q for k in range(len(t))]
    planner.reset()
    again = [planner.step(f[k], omega[k]).q for k in range(len(t))]
    assert np.array_equal(np.array(first), np.array(again))


@pytest.mark.ros            # run(parallel=True) forks the washout's process
@pytest.mark.parametrize('name', ['3dof', 'hexapod', '3dof-preview'])
def test_the_washout_in_a_second_process_gives_the_same_run_bit_for_bit(models, name):
    """run(parallel=True): the wishes made in a forked process a block ahead of
    the limiter; blocks handed to on_block as they are final, in order. With
    the look-ahead (the 3-DOF file's preview off) and with the preview (its
    own: planned before, in this process)."""
    model = models[name.split('-')[0]]
    params = load_cueing('config/stewart_6dof.yaml' if name == 'hexapod' else None)
    assert params.limiter == 'inverse_dynamics'
    previewed = name == '3dof-preview'
    assert (params.limiter_settings['preview.slope'] > 0) == (name != 'hexapod')
    if name == '3dof':
        params = params.replace(limiter_settings={**params.limiter_settings,
                                                  'preview.slope': 0.0})
    t, f, omega = vehicle(2 * BLOCK + 123, seed=3)
    f[:, 0] *= 4.0                          # hard enough for the limiter to act
    blocks = []
    together = run(model, params, t, f, omega, parallel=True,
                   on_block=lambda times, samples: blocks.append((times.copy(),
                                                                 samples.copy())))
    alone = run(model, params, t, f, omega)
    # limited samples, and (without the preview's gain) the washout's own, judged
    # ahead in the second process
    assert np.any(alone.given_up > 0)
    if not previewed:
        assert np.all(alone.q == alone.desired_q, axis=1).sum() > 100
    for field in ('t', 'q', 'qd', 'qdd', 'given_up', 'desired_q', 'desired_qd', 'desired_qdd',
                  'f', 'omega'):
        assert np.array_equal(getattr(together, field), getattr(alone, field)), field
    assert list(together.limit) == list(alone.limit)
    assert [len(b[0]) for b in blocks] == [BLOCK, BLOCK, 123]
    assert np.array_equal(np.concatenate([b[0] for b in blocks]), alone.t)
    assert np.array_equal(np.concatenate([b[1] for b in blocks]),
                          np.hstack([alone.q, alone.qd, alone.qdd]))


@pytest.mark.ros            # run(parallel=True) forks the washout's process
def test_a_run_in_two_processes_counts_held_inputs_and_leaves_no_process(models):
    import multiprocessing
    t, f, omega = vehicle(BLOCK + 500)
    f[BLOCK + 10:BLOCK + 20, 1] = np.nan
    together = run(models['hexapod'], NONE, t, f, omega, parallel=True)
    assert together.held == 10 == run(models['hexapod'], NONE, t, f, omega).held
    assert multiprocessing.active_children() == []


@pytest.mark.ros            # run(parallel=True) forks the washout's process
def test_an_error_in_a_block_ends_the_washout_process(models):
    import multiprocessing
    t, f, omega = vehicle(3 * BLOCK)

    def stop(times, samples):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        run(models['3dof'], NONE, t, f, omega, parallel=True, on_block=stop)
    assert multiprocessing.active_children() == []
