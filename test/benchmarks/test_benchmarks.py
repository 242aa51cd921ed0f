"""Each benchmark script in its quickest form prints its table, every figure a
finite number. No figure is judged: speed is measured, never asserted."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

# every benchmark runs as its own process (python -m benchmarks.NAME); the ones
# whose quickest form takes 10 s of CPU or more are in the slow tier
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


@pytest.mark.slow
def test_node_prints_the_node_with_and_without_markers_next_to_the_echo():
    rows = run('benchmarks.node', '--quick')
    t = {k: v for k, v in table(rows, 'target').items() if not k.startswith(':')}
    assert set(t) == {'echo', 'node, markers on', 'node, markers off'}
    for target in t:
        median, p99, worst = numbers(t[target][:3])
        assert 0 < median <= p99 <= worst
        lost, sent = (int(v) for v in t[target][3].split(' / '))
        assert sent > 0 and 0 <= lost <= sent
    # the ratios are those of the first table's figures (their signs and sizes are
    # the host's: no bound on them here), to the digits printed
    latency = {target: numbers(t[target][:2]) for target in t}

    def ratio_of(cells: list[str], over: str, of: str) -> None:
        for printed, a, b in zip(numbers(cells), latency[of], latency[over]):
            assert printed == pytest.approx(a / b, rel=0.01, abs=0.006), (cells, a, b)
    ratios = table(rows, 'ratio to the echo')
    for target in ('node, markers on', 'node, markers off'):
        ratio_of(ratios[target], 'echo', target)
    cost = table(rows, "the markers' cost")
    ratio_of(cost['node, markers on / markers off'], 'node, markers off', 'node, markers on')
    costs = table(rows, 'markers, per array')
    for part in ("node's thread (snapshot, request, raw publish)",
                 'renderer process (build, serialize)'):
        assert all(v > 0 for v in numbers(costs[part]))


@pytest.mark.slow
def test_cueing_prints_the_check_values_and_the_costs():
    rows = run('benchmarks.cueing', '--quick')

    def body(first: str) -> dict[str, list[str]]:
        """The table's rows, up to the next table of as many columns."""
        out = {}
        for k, v in table(rows, first).items():
            if k in ('machine', 'cue, limiter'):
                break
            if not k.startswith(':'):
                out[k] = v
        return out

    checks = body('check value (limiter none, 1 kHz)')
    assert len(checks) >= 20
    for cells in checks.values():
        numbers(cells)
    costs = body('machine')
    assert set(costs) == {'3-DOF', 'hexapod'}
    assert all(v > 0 for cells in costs.values() for v in numbers(cells[1:]))
    offline = body('cue, limiter')
    assert set(offline) == {'none', 'inverse_dynamics', 'inverse_dynamics + preview'}
    assert all(v > 0 for cells in offline.values() for v in numbers(cells[2:5]))


@pytest.mark.slow
def test_cueing_limiter_prints_both_rmses_and_every_output_ok():
    rows = run('benchmarks.cueing_limiter', '--quick')
    start = next(i for i, r in enumerate(rows) if r[0] == 'log')
    body = [r for r in rows[start + 2:] if len(r) == len(rows[start])]
    assert {r[1] for r in body} == {'flight_sim_dynamics', 'stewart_6dof'}
    for cells in body:
        limited, a, b, scale, ratio, b_m, scale_m, ratio_m, not_ok, us, us_pure = numbers(
            cells[3:])
        assert 0 <= limited <= 100 and a >= 0 and b >= 0 and 0 <= scale <= 1
        # the margins only narrow the limits: the gain scale that fits them is no larger
        assert b_m >= 0 and 0 <= scale_m <= scale and ratio_m > 0
        assert not_ok == 0 and us > 0 and us_pure > 0 and ratio > 0
