"""Ctrl-C is a normal way to stop: exit status 130, at most one line, no
traceback, whenever it comes (while the modules load, or while the demo's
planner and monitor callbacks run)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]

#: Runs the command line as ``python -m`` or as the console script does, with
#: a SIGINT delivered the moment numpy starts loading (deterministic); Ctrl-C
#: on, as in a terminal, even where the test run was started with SIGINT
#: ignored (a background job of a shell without job control).
SIGINT_WHILE_LOADING = '''
import importlib.abc, os, signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)

class Interrupt(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == 'numpy':
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, Interrupt())
sys.argv = ['flight-sim-dynamics', 'example', 'vertical', '-o', sys.argv[2]]
if sys.argv and {route!r} == 'script':
    from flight_sim_dynamics.__main__ import main
    sys.exit(main())
import runpy
runpy.run_module('flight_sim_dynamics', run_name='__main__', alter_sys=True)
'''


@pytest.mark.parametrize('route', ['module', 'script'])
def test_ctrl_c_while_the_command_line_loads_is_one_line_and_130(tmp_path, route):
    out = tmp_path / 'v.csv'
    done = subprocess.run([sys.executable, '-c', SIGINT_WHILE_LOADING.format(route=route),
                           'x', str(out)], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 130, done.stderr
    assert 'Traceback' not in done.stderr and len(done.stderr.splitlines()) <= 1, done.stderr
    assert not out.exists()


def test_ctrl_c_stops_the_demo_quietly(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED='1', MPLBACKEND='Agg')
    proc = subprocess.Popen([sys.executable, '-m', 'flight_sim_dynamics', 'demo', '-o',
                             str(tmp_path / 'demo.png'), '--motions', 'vertical'],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 60
        while not any('[demo] node up' in line for line in lines):
            assert proc.poll() is None and time.monotonic() < deadline, ''.join(lines)
            time.sleep(0.05)
        time.sleep(1.5)                     # the planner's timer and the monitor at work
        seen = len(lines)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(30) == 130, ''.join(lines)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(5)
    after = ''.join(lines[seen:])
    assert 'FATAL' not in after and 'Traceback' not in after, after
    assert len([line for line in lines[seen:] if not line.startswith('[demo] t=')]) <= 1, after
