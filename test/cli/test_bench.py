"""``flight-sim-dynamics bench``: a quick run writes its page and figure, and
the accuracy side is right. No timing is asserted (the machine is shared)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import bench
from flight_sim_dynamics.cli import main as cli

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def row(md: str, variant: str) -> list[str]:
    line = next(line for line in md.splitlines() if line.startswith(f'| `{variant}` |'))
    return [c.strip() for c in line.strip('|').split('|')]


def newtons(cell: str) -> float:
    return float(re.match(r'([0-9.e+-]+) N', cell).group(1))


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('bench')
    rc = cli.main(['bench', '--quick', '--out-dir', str(out)])
    return rc, out, (out / 'scenes.md').read_text()


def test_quick_run_writes_a_table_row_per_variant_and_the_figure(quick_run):
    rc, out, md = quick_run
    assert rc == 0
    for v in bench.variants():
        cells = row(md, v.key)
        assert len(cells) == 4 + len(fsd.machine_of(fsd.load_model()).bench_motions)
        median, p99 = float(cells[2]), float(cells[3])
        assert 0 < median <= p99
    assert (out / 'scenes.png').read_bytes()[:8] == PNG_SIGNATURE


def test_full_is_exact_and_simplified_models_are_not(quick_run):
    md = quick_run[2]
    assert all(newtons(c) == 0.0 for c in row(md, 'full')[4:])
    assert newtons(row(md, 'quasi_static')[-1]) > 1.0          # violent: inertia matters
    assert newtons(row(md, 'full - gravity')[4]) > 10.0         # vertical: gravity dominates


def test_variants_cover_scenes_and_single_effects():
    keys = {v.key: v for v in bench.variants()}
    assert keys['full'].kind == 'reference'
    for scene in ('quasi_static', 'platform_only', 'payload'):
        assert scene in keys
    for effect in ('gravity', 'platform_inertia', 'leg_inertia', 'crank_inertia',
                   'velocity_products'):
        v = keys[f'full - {effect}']
        assert v.kind == 'drops' and not getattr(v.model.effects, effect)
    assert keys['full + friction'].model.effects.friction
    assert keys['payload'].kind == 'adds'


def test_force_errors_of_full_against_itself_are_zero():
    full = fsd.load_model()
    motions = bench.exact_motions(100.0)
    reference = {n: fsd.solve_batch(full, *m[1:]).force for n, m in motions.items()}
    assert set(bench.force_errors(full, motions, reference).values()) == {0.0}


def test_estimated_accelerations_get_better_with_rate():
    errors = {(s, m, r): e for s, m, r, e in bench.estimator_errors(fsd.load_model())}
    for source in ('pose + twist', 'pose only'):
        for method in bench.ESTIMATORS:
            by_rate = [errors[source, method, r] for r in bench.ESTIMATOR_RATES]
            assert by_rate[0] > by_rate[1] > by_rate[2] > 0.0


def test_estimator_keeps_exact_twists():
    q, qd, _ = bench.estimated('backward2', 250.0, 'violent', twist=True)
    violent = fsd.machine_of(fsd.load_model()).motions['violent']
    np.testing.assert_array_equal(qd, violent.sampled(250.0)[2])


def test_update_docs_needs_the_repository_docs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(['bench', '--quick', '--update-docs']) == 2
    assert 'scenes.md' in capsys.readouterr().err
    assert not (tmp_path / 'docs').exists()


def test_cli_registers_bench():
    args = cli.build_parser().parse_args(['bench', '--quick', '--out-dir', 'x', '--no-plot'])
    assert args.quick and args.no_plot and args.out_dir == 'x'
    assert callable(args.handler)


def test_the_figure_caption_describes_the_bar_chart_and_the_docs_page_has_it(quick_run):
    """The caption under scenes.png is written by bench with the figure: bars
    per variant (error left, time right), not a scatter of time against error;
    docs/scenes.md is the page bench writes."""
    md = quick_run[2]
    caption = md.split('](scenes.png)', 1)[1].split('##', 1)[0].strip()
    assert 'bar' in caption and 'x =' not in caption, caption
    docs = (Path(__file__).resolve().parents[2] / 'docs' / 'scenes.md').read_text()
    assert caption in docs and 'dotted floor' not in docs


def test_the_3dof_machines_payload_and_friction_are_not_absent():
    """Its packaged file gives both (140 kg, 20 N s/m): their rows are measured."""
    assert not any(v.absent for v in bench.variants())
