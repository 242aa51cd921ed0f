"""Each benchmark script in its quickest form prints its table, every figure a
finite number. No figure is judged: speed is measured, never asserted."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

# every benchmark runs as its own process (python -m benchmarks.NAME)
pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def run(*args: str) -> list[list[str]]:
    """The table rows ``python -m benchmarks.<args>`` prints, cells split."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    proc = subprocess.run([sys.executable, '-m', *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0].startswith('# ') and 'commit' in lines[0]
    return [[c.strip() for c in line.strip('|').split('|')] for line in lines
            if line.startswith('| ')]


def numbers(cells: list[str]) -> list[float]:
    values = [float(c.replace(',', '').rstrip('x')) for c in cells]
    assert all(math.isfinite(v) for v in values), cells
    return values


def table(rows: list[list[str]], first_column: str) -> dict[str, list[str]]:
    """The table whose header starts with ``first_column``: its rows by first cell."""
    start = next(i for i, r in enumerate(rows) if r[0] == first_column)
    out = {}
    for r in rows[start + 1:]:
        if len(r) != len(rows[start]) or r[0] in rows[start]:
            break
        out[r[0]] = r[1:]
    return out


def test_solve_prints_kernel_and_python_figures():
    t = table(run('benchmarks.solve', '--quick'), 'path')
    assert {'kernel', 'Python', 'Python / kernel'} <= set(t)
    for path in ('kernel', 'Python'):
        assert all(v > 0 for v in numbers(t[path]))


def test_dispatch_prints_both_machines_direct_and_through_fsd():
    t = {k: v for k, v in table(run('benchmarks.dispatch', '--quick'), 'machine').items()
         if not k.startswith(':')}
    assert set(t) in ({'3-DOF (kernel)', 'hexapod'}, {'3-DOF (Python)', 'hexapod'})
    for cells in t.values():
        direct, dispatched, _, ratio = numbers(cells)
        assert direct > 0 and dispatched > 0 and ratio > 0


def test_csv_prints_the_end_to_end_times():
    t = table(run('benchmarks.csv', '--quick'), 'flight-sim-dynamics solve')
    assert all(v > 0 for v in numbers(t['CSV in, CSV out']))
    assert all(v > 0 for v in numbers(t['CSV in, .npz out']))


def test_twin_prints_the_real_time_factors_and_writes_the_figure(tmp_path):
    png = tmp_path / 'tracking.png'
    rows = run('benchmarks.twin', '--quick', '--out', str(png))
    for first in ('path', '6-DOF path'):        # the 3-DOF machine, the hexapod
        speed = table(rows, first)
        for path in ('kernel', 'Python'):
            assert all(v > 0 for v in numbers(speed[path][1:]))
    tracking = table(rows, 'motion')
    assert len(numbers(tracking['vertical'][1:])) == 2      # max and RMS of a row
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_node_prints_the_node_with_and_without_markers_next_to_the_echo():
    rows = run('benchmarks.node', '--quick')
    t = {k: v for k, v in table(rows, 'target').items() if not k.startswith(':')}
    assert set(t) == {'echo', 'node, markers on', 'node, markers off'}
    for target in t:
        median, p99, worst = numbers(t[target][:3])
        assert 0 < median <= p99 <= worst
        lost, sent = (int(v) for v in t[target][3].split(' / '))
        assert sent > 0 and 0 <= lost <= sent
    ratios = table(rows, 'ratio to the echo')
    for target in ('node, markers on', 'node, markers off'):
        assert all(v > 0 for v in numbers(ratios[target]))
    cost = table(rows, "the markers' cost")
    assert all(v > 0 for v in numbers(cost['node, markers on / markers off']))
    costs = table(rows, 'markers, per array')
    for part in ("node's thread (snapshot, request, raw publish)",
                 'renderer process (build, serialize)'):
        assert all(v > 0 for v in numbers(costs[part]))
