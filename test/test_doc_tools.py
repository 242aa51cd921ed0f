"""The documentation generators under scripts/ (run as ``python -m scripts.<name>``
from the repository root): the reproduction table of docs/reproduction.md,
regenerated into a temporary copy, and the node parameter table."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flight_sim_dynamics.cli import csv_io

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = '<!-- reproduction-table:begin -->', '<!-- reproduction-table:end -->'


def test_reproduction_table_updates_a_copy_of_the_page(tmp_path):
    page = tmp_path / 'reproduction.md'
    shutil.copy(ROOT / 'docs' / 'reproduction.md', page)
    before = page.read_text()
    figures, work = tmp_path / 'figures', tmp_path / 'work'
    proc = subprocess.run([sys.executable, '-m', 'scripts.reproduction_table', '--figures',
                           str(figures), '--work', str(work), '--update', str(page)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    after = page.read_text()
    # only the marked block changed, and it is what the command printed
    head, rest = after.split(BEGIN, 1)
    block, tail = rest.split(END, 1)
    assert head == before.split(BEGIN, 1)[0] and tail == before.split(END, 1)[1]
    assert block.strip() == proc.stdout.strip()
    for name in ('vertical', 'rectilinear', 'general'):
        assert (figures / f'{name}.png').read_bytes()[:4] == b'\x89PNG'
    # the peak |force| of leg A of the general motion is the one of the solve output
    out = csv_io.read_csv(work / 'out' / 'general.csv', required=('t', 'force_a'),
                          allow_extra=True, text_columns=('status',))
    i = int(np.argmax(np.abs(out['force_a'])))
    row = next(line for line in block.splitlines() if line.startswith('| general | A |'))
    cells = [c.strip() for c in row.strip('|').split('|')]
    assert float(cells[2].replace('−', '-')) == round(float(out['force_a'][i]), 3)
    assert float(cells[3]) == round(float(out['t'][i]), 2)


def test_node_param_table_lists_every_node_parameter():
    from flight_sim_dynamics.config.parameters import NODE_PARAMETERS

    proc = subprocess.run([sys.executable, '-m', 'scripts.node_param_table', '--node'],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith('| name | type | unit | default |')
    for spec in NODE_PARAMETERS:
        assert any(line.startswith(f'| `{spec.name}` |') for line in lines), spec.name
