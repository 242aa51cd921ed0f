"""Smoke test of the performance benchmark (``python -m benchmarks.performance``):
a quick run without ROS writes a complete report to a temporary directory
(never docs/) and prints the summary table. No timing is asserted: the
machine is shared and the figures of a quick run mean nothing."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp('performance')
    out = out_dir / 'performance.md'
    raw = out_dir / 'performance.json'
    docs = ROOT / 'docs' / 'performance.md'
    before = docs.stat().st_mtime_ns if docs.exists() else None
    proc = subprocess.run([sys.executable, '-m', 'benchmarks.performance', '--quick',
                           '--no-node', '--out', str(out), '--json', str(raw)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    after = docs.stat().st_mtime_ns if docs.exists() else None
    return proc, out, raw, before, after


def test_quick_run_succeeds_and_leaves_docs_alone(quick_run):
    proc, out, raw, before, after = quick_run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert out.is_file() and raw.is_file()
    assert before == after, 'the smoke run must not touch docs/performance.md'


def test_prints_the_summary_table(quick_run):
    proc = quick_run[0]
    lines = proc.stdout.splitlines()
    assert lines[0].startswith('| # | figure | measured | target | verdict | load avg')
    for figure in ('`fsd.solve` full, median', '`fsd.solve` full, p99',
                   '`fsd.solve` quasi_static, median', '`sol.cond` on demand',
                   '`solve_batch` throughput', 'batch vs per-cycle',
                   'CSV through `flight-sim-dynamics solve`', 'node latency', 'soak'):
        assert any(figure in line for line in lines), figure
    # every measured row says met or MISSED (with the gap) next to its target
    rows = [line for line in lines if line.startswith('| 1 ') or line.startswith('| 2 ')
            or line.startswith('| 3 ')]
    assert rows
    for row in rows:
        verdict = row.strip('|').split('|')[4].strip()
        assert verdict.startswith(('met', 'MISSED: ')), row
        if verdict.startswith('MISSED'):
            assert 'x over' in verdict or 'x under' in verdict or 'lost' in verdict, row
    assert 'load average' in lines[-1]


def test_report_has_every_part(quick_run):
    md = quick_run[1].read_text()
    assert md.startswith('# Performance\n')
    for needed in ('## Summary', '## Machine and command', 'CPU:', 'load average', 'Python 3',
                   'speed reference (`sum(range(1000))`',
                   'numpy', 'rclpy', 'python -m benchmarks.performance --quick --no-node',
                   '## 1. Per-cycle solve', '## 2. Batch solve', '## 3. CSV end to end',
                   '## Profiles', '### The solver: where one `fsd.solve` goes',
                   'kernel us', 'Python code us', 'speed-up', '`fsd.solve_batch`',
                   '- checked figures: '):
        assert needed in md, needed
    # the solver profile says which implementation ran (the kernel: CI builds it)
    profile = md.split('### The solver', 1)[1]
    from flight_sim_dynamics.core import kernel
    if kernel.enabled():
        assert 'ran the compiled kernel' in profile and 'one thread' in profile
    else:
        assert 'ran **the Python code' in profile
    # ROS parts were skipped and say so
    assert 'skipped (--no-node)' in md
    assert '## 4. Node latency' not in md


def test_batch_and_per_cycle_agree(quick_run):
    import json

    data = json.loads(quick_run[2].read_text())
    diffs = data['results']['batch']['diffs']
    assert diffs['force'] <= 1e-9
    assert data['results']['batch']['status_mismatch'] == 0
    assert data['results']['csv']['rows_out'] == data['results']['csv']['n']


def test_bench_callbacks_script_answers_every_setpoint(tmp_path):
    """benchmarks/bench_callbacks.py drives a real node's callbacks with both inputs
    and exits non-zero unless every setpoint was answered and none rejected."""
    env = dict(os.environ)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    proc = subprocess.run([sys.executable, '-m', 'benchmarks.bench_callbacks',
                           '--setpoints', '40', '--repeat', '2'],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    lines = [line for line in proc.stdout.splitlines() if line.startswith('three topics')]
    assert len(lines) == 2 and 'platform_setpoint' in lines[0]
