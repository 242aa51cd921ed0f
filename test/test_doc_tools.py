"""The documentation generators under scripts/ (``python -m scripts.<name>``
from the repository root) regenerate what the pages show, and the committed
pages are current."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flight_sim_dynamics.cli import csv_io
from scripts import DOCS, block, markers, replace_block
from scripts import node_param_table

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parent.parent


def test_reproduction_table_regenerates_the_page(tmp_path):
    page = tmp_path / 'reproduction.md'
    shutil.copy(DOCS / 'reproduction.md', page)
    before = page.read_text()
    figures, work = tmp_path / 'figures', tmp_path / 'work'
    proc = subprocess.run([sys.executable, '-m', 'scripts.reproduction_table', '--figures',
                           str(figures), '--work', str(work), '--update', str(page)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    # the committed page is current: regenerating it changes nothing
    assert page.read_text() == before
    assert block(page, 'reproduction-table') == proc.stdout.strip('\n')
    for name in ('vertical', 'rectilinear', 'general'):
        assert (figures / f'{name}.png').read_bytes()[:4] == b'\x89PNG'
        assert (DOCS / f'{name}.png').is_file()
    # the peak |force| of leg A of the general motion is the one of the solve output
    out = csv_io.read_csv(work / 'out' / 'general.csv', required=('t', 'force_a'),
                          allow_extra=True, text_columns=('status',))
    i = int(np.argmax(np.abs(out['force_a'])))
    row = next(line for line in proc.stdout.splitlines() if line.startswith('| general | A |'))
    cells = [c.strip() for c in row.strip('|').split('|')]
    assert float(cells[2].replace('−', '-')) == round(float(out['force_a'][i]), 3)
    assert float(cells[3]) == round(float(out['t'][i]), 2)


def test_parameter_tables_are_current_and_complete():
    from flight_sim_dynamics.config.parameters import MODEL_PARAMETERS, NODE_PARAMETERS
    from flight_sim_dynamics.config.schema import CUEING_NODE_PARAMETERS, SIM_PARAMETERS
    from flight_sim_dynamics.config.cueing import PARAMETER_SPECS
    from flight_sim_dynamics.machines import STEWART

    generated = node_param_table.blocks()
    for (page, name), text in generated.items():
        assert block(DOCS / page, name) == text, \
            f'docs/{page} is stale: run python -m scripts.node_param_table --update'
    node = generated[('node.md', 'node-parameters')]
    twin = generated[('twin.md', 'twin-parameters')]
    for spec in NODE_PARAMETERS:
        assert f'| `{spec.name}` |' in node, spec.name
    for spec in MODEL_PARAMETERS:
        folded = spec.name.startswith(('geometry.', 'bodies.'))
        name = spec.name.rsplit('.', 1)[-1] if folded else f'`{spec.name}`'
        assert name in node, spec.name
    for spec in SIM_PARAMETERS:
        assert f'| `{spec.name}` |' in twin, spec.name
    hexapod = generated[('node.md', 'hexapod-parameters')]
    for spec in STEWART.parameter_specs:
        assert f'| `{spec.name}` |' in hexapod, spec.name
    cueing = generated[('cueing_node.md', 'cueing-node-parameters')]
    for spec in CUEING_NODE_PARAMETERS + PARAMETER_SPECS:
        assert f'| `{spec.name}` |' in cueing, spec.name


def test_node_param_table_prints_without_writing():
    proc = subprocess.run([sys.executable, '-m', 'scripts.node_param_table'],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    # the node's, the 3-DOF machine's, the hexapod's, the twin's, the cueing node's
    assert proc.stdout.count('| name | type | unit | default | range | meaning |') == 5


def test_replace_block_touches_only_the_block(tmp_path):
    begin, end = markers('x')
    page = tmp_path / 'page.md'
    page.write_text(f'head\n{begin}\nold\n{end}\ntail\n')
    replace_block(page, 'x', 'new\n')
    assert page.read_text() == f'head\n{begin}\nnew\n{end}\ntail\n'
    page.write_text('no markers\n')
    with pytest.raises(SystemExit):
        replace_block(page, 'x', 'new')
    assert page.read_text() == 'no markers\n'


def test_stewart_workspace_tables_are_current():
    from scripts import stewart_tables

    assert block(DOCS / 'stewart.md', 'stewart-workspace') == stewart_tables.workspace_block(), \
        'docs/stewart.md is stale: run python -m scripts.stewart_tables --update docs/stewart.md'


def test_stewart_tables_regenerate_every_block_and_the_figure(tmp_path):
    """A quick run rewrites each block of a copy of docs/stewart.md with the
    tables its tool prints (timings differ from run to run: their rows and
    columns are checked, not their figures) and draws the frame of animate."""
    from flight_sim_dynamics.cli import bench

    page, png = tmp_path / 'stewart.md', tmp_path / 'frame.png'
    shutil.copy(DOCS / 'stewart.md', page)
    proc = subprocess.run([sys.executable, '-m', 'scripts.stewart_tables', '--quick', '--update',
                           str(page), '--figure', str(png)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert block(page, 'stewart-workspace') == block(DOCS / 'stewart.md', 'stewart-workspace')
    effects = block(page, 'stewart-effects')
    for variant in bench.variants('config/stewart_6dof.yaml'):
        assert f'| `{variant.key}` |' in effects
    committed = block(DOCS / 'stewart.md', 'stewart-effects')
    rows = [line.split('|')[1] for line in committed.splitlines() if line.startswith('| `')]
    assert rows == [line.split('|')[1] for line in effects.splitlines() if line.startswith('| `')]
    speed = block(page, 'stewart-speed')
    assert '| solve (kernel) |' in speed and '| solve_batch |' in speed
    assert png.read_bytes()[:4] == b'\x89PNG'
    figure = DOCS / 'stewart_animation.png'
    assert figure.read_bytes()[:4] == b'\x89PNG' and figure.stat().st_size < 150_000
