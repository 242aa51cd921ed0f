"""``flight-sim-dynamics bench --params <hexapod>``: a row per scene and per
effect the hexapod models (no cranks), the force errors of its bench motions
against ``full``, the estimator on its six coordinates. No timing is asserted."""
from __future__ import annotations

import re

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import bench
from flight_sim_dynamics.cli import main as cli

PARAMS = 'config/stewart_6dof.yaml'
MACHINE = fsd.machine_of(fsd.load_model(PARAMS))


def newtons(cell: str) -> float:
    return float(re.match(r'([0-9.e+-]+) N', cell).group(1))


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('bench')
    rc = cli.main(['bench', '--quick', '--params', PARAMS, '--out-dir', str(out)])
    return rc, out, (out / 'scenes.md').read_text()


def rows(md: str) -> dict[str, list[str]]:
    return {cells[0].strip('`'): cells for cells in
            ([c.strip() for c in line.strip('|').split('|')]
             for line in md.splitlines() if line.startswith('| `'))}


def test_a_row_per_variant_of_the_effects_the_hexapod_models(quick_run):
    rc, out, md = quick_run
    assert rc == 0 and (out / 'scenes.png').read_bytes()[:4] == b'\x89PNG'
    table = rows(md)
    assert set(table) == {v.key for v in bench.variants(PARAMS)}
    assert not any('crank' in key for key in table)
    for effect in ('gravity', 'platform_inertia', 'leg_inertia', 'velocity_products'):
        assert f'full - {effect}' in table
    assert 'full + friction' in table and 'payload' in table
    for cells in table.values():
        assert len(cells) == 4 + len(MACHINE.bench_motions)
    assert all(newtons(c) == 0.0 for c in table['full'][4:])
    assert newtons(table['full - gravity'][4]) > 100.0          # gentle: gravity dominates
    assert newtons(table['quasi_static'][-1]) > newtons(table['quasi_static'][4])
    assert '| max force error, violent |' in md.splitlines()[next(
        i for i, line in enumerate(md.splitlines()) if line.startswith('| streamed'))]


def test_variants_are_the_hexapods_models():
    for v in bench.variants(PARAMS):
        assert fsd.machine_of(v.model) is MACHINE


def test_force_errors_are_those_of_solve_batch():
    full = fsd.load_model(PARAMS)
    quasi = fsd.load_model(PARAMS, scene='quasi_static')
    motions = bench.exact_motions(100.0, MACHINE)
    assert set(motions) == set(MACHINE.bench_motions)
    reference = {n: fsd.solve_batch(full, *m[1:]).force for n, m in motions.items()}
    errors = bench.force_errors(quasi, motions, reference)
    for name, m in motions.items():
        want = np.abs(fsd.solve_batch(quasi, *m[1:]).force - reference[name]).max()
        assert errors[name] == want > 0.0


def test_estimated_accelerations_of_six_coordinates_get_better_with_rate():
    errors = {(s, m, r): e for s, m, r, e in bench.estimator_errors(fsd.load_model(PARAMS))}
    for source in ('pose + twist', 'pose only'):
        for method in bench.ESTIMATORS:
            by_rate = [errors[source, method, r] for r in bench.ESTIMATOR_RATES]
            assert by_rate[0] > by_rate[1] > by_rate[2] > 0.0


def test_update_docs_is_for_the_default_machine(capsys):
    assert cli.main(['bench', '--quick', '--update-docs', '--params', PARAMS]) == 2
    assert '--out-dir' in capsys.readouterr().err


def test_effects_the_default_hexapod_lacks_are_said_absent_not_exact(quick_run):
    """stewart_6dof.yaml has neither payload (0 kg) nor friction (0): their
    rows say the effect is absent from the model, and a note says why."""
    rc, out, md = quick_run
    table = rows(md)
    for key in ('payload', 'full + friction'):
        assert all('absent' in cell for cell in table[key][4:]), table[key]
    assert 'payload.mass 0 kg' in md and 'friction' in md.split('note:', 1)[1]
    keys = {v.key: v for v in bench.variants(PARAMS)}
    assert keys['payload'].absent and keys['full + friction'].absent
    assert not any(v.absent for k, v in keys.items() if k not in ('payload', 'full + friction'))


def test_a_payload_of_the_params_file_is_no_longer_absent(tmp_path, capsys):
    """... and bench, which sets the scenes itself, notes no payload the full
    scene leaves out."""
    path = tmp_path / 'heavy.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    machine: stewart_6dof\n'
                    '    payload: {mass: 80.0}\n')
    keys = {v.key: v for v in bench.variants(str(path))}
    assert not keys['payload'].absent and keys['full + friction'].absent
    assert 'note:' not in capsys.readouterr().err


def test_the_hexapod_cli_notes_a_payload_the_scene_leaves_out(tmp_path, capsys):
    path = tmp_path / 'heavy.yaml'
    path.write_text('flight_sim_dynamics:\n  ros__parameters:\n    machine: stewart_6dof\n'
                    '    payload: {mass: 80.0}\n')
    assert cli.main(['example', 'gentle', '--params', str(path), '-o',
                     str(tmp_path / 'g.csv')]) == 0
    err = capsys.readouterr().err
    assert 'note:' in err and 'payload.mass' in err, err
