"""The speed/accuracy benchmark (``flight-sim-dynamics bench``): a quick run
writes its report and figure, and the accuracy side is right. No timing is
asserted (the machine is shared and noisy)."""
from __future__ import annotations

import re

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import bench as bench_command
from flight_sim_dynamics.cli import bench_cases as bench
from flight_sim_dynamics.cli import main as cli

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('bench')
    rc = bench_command.main(['--quick', '--out-dir', str(out)])
    return rc, out


def test_quick_run_writes_the_report_and_the_figure(quick_run, capsys):
    rc, out = quick_run
    assert rc == 0
    md = (out / 'scenes.md').read_text()
    assert md.startswith('# ')
    assert '## Summary' in md
    for needed in ('## Machine and command', 'flight-sim-dynamics bench --quick',
                   'numpy', 'Python', '## Missing accelerations', '## The violent motion',
                   '(scenes.png)'):
        assert needed in md
    for variant in ('full', 'quasi_static', 'platform_only', 'payload', 'full - leg_inertia',
                    'full - gravity', 'full + friction'):
        assert f'| `{variant}` |' in md
    assert (out / 'scenes.png').read_bytes()[:8] == PNG_SIGNATURE


def test_report_says_full_is_exact_and_quasi_static_is_not(quick_run):
    _, out = quick_run
    md = (out / 'scenes.md').read_text()
    full_row = next(line for line in md.splitlines() if line.startswith('| `full` | reference'))
    cells = [c.strip() for c in full_row.strip('|').split('|')]
    assert cells[-4:] == ['0 N (0 %)'] * 4          # max error on the four motions
    qs_row = next(line for line in md.splitlines() if line.startswith('| `quasi_static` |'))
    violent = qs_row.strip('|').split('|')[-1]
    assert float(re.match(r'\s*([0-9.e+-]+) N', violent).group(1)) > 1.0


def test_error_of_full_against_itself_is_exactly_zero():
    full = fsd.load_model()
    ms = bench.motion_set(full, 100.0)
    variants = bench.variants()
    assert variants[0].key == 'full' and variants[0].kind == bench.REFERENCE
    errors = bench.variant_errors(variants[0], ms)
    assert set(errors) == set(bench.MOTIONS)
    for e in errors.values():
        assert e.max == 0.0 and e.rms == 0.0 and e.peak > 0.0
    qs = next(v for v in variants if v.key == 'quasi_static')
    e = bench.variant_errors(qs, ms)['violent']
    assert e.max > 0.05 * e.peak          # inertia matters on the violent motion
    assert e.rms > 0.0


def test_variants_cover_scenes_and_single_effects():
    keys = {v.key: v for v in bench.variants()}
    for scene in ('full', 'quasi_static', 'platform_only', 'payload'):
        assert scene in keys
    for effect in ('gravity', 'platform_inertia', 'leg_inertia', 'crank_inertia',
                   'velocity_products'):
        v = keys[f'full - {effect}']
        assert v.kind == bench.DROPS and not getattr(v.model.effects, effect)
    assert keys['full + friction'].model.effects.friction
    assert keys['full + friction'].kind == bench.ADDS
    assert keys['payload'].kind == bench.ADDS


def test_estimated_accelerations_get_better_with_rate():
    full = fsd.load_model()
    ms = bench.motion_set(full, 100.0)
    cases = bench.estimator_cases(full, ms.peak)
    for source in ('twist', 'pose'):
        for method in ('backward', 'backward2'):
            errs = [bench.find_estimator(cases, source, method, r).steady['violent'].max
                    for r in bench.ESTIMATOR_RATES]
            assert errs[0] > errs[1] > errs[2] > 0.0


def test_estimate_feeds_exact_twists_through():
    q, qd_used, qdd_used, qd, qdd = bench.estimate('backward2', 250.0, 'violent', twist=True)
    np.testing.assert_array_equal(qd_used, qd)
    assert np.abs(qdd_used - qdd)[bench.STARTUP_SAMPLES:].max() < 0.2 * np.abs(qdd).max()


def test_cli_registers_bench():
    parser = cli.build_parser()
    args = parser.parse_args(['bench', '--quick', '--out-dir', 'x', '--no-plot'])
    assert args.quick and args.no_plot and args.out_dir == 'x'
    assert callable(args.handler)


def test_sign_test():
    assert bench.sign_test(np.ones(20)) < 1e-5
    assert bench.sign_test(np.array([1.0, -1.0] * 10)) == 1.0
    assert bench.sign_test(np.zeros(5)) == 1.0
    assert abs(bench.sign_test(np.array([1.0] * 9 + [-1.0])) - 22 / 1024) < 1e-12


def test_estimation_benchmark_runs_the_bench_study_on_planner_motions():
    from benchmarks import estimation

    rows = estimation.rows([50.0, 200.0], 0.1, ['cueing'])
    assert len(rows) == 2 * 2 * 2                      # rates x streams x estimators
    by = {(r[1], r[2], r[3]): r for r in rows}
    for stream in ('pose+twist', 'pose only'):
        for method in ('backward', 'backward2'):
            slow, fast = by[(50.0, stream, method)], by[(200.0, stream, method)]
            assert fast[4] < slow[4] and fast[7] < slow[7]      # force, acceleration error
            assert 0.0 < fast[6] <= fast[4] and fast[5] > 0.0     # RMS <= max, % given
