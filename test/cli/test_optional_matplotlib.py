"""matplotlib is an optional extra (``pip install 'flight_sim_dynamics[plot]'``):
the library, the node and ``solve`` work without it; a subcommand that draws
fails with one line naming the extra, exit status 2. Each check runs in a
fresh interpreter where ``import matplotlib`` fails (None in sys.modules)."""
from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# Block matplotlib, run the command line with the given argv, then report
# whether anything of matplotlib got loaded.
WITHOUT_MATPLOTLIB = '''
import sys
sys.modules['matplotlib'] = None
import flight_sim_dynamics
import flight_sim_dynamics.ros.node
from flight_sim_dynamics.cli.main import main
rc = main(sys.argv[1:])
loaded = [m for m in sys.modules if m.startswith('matplotlib') and sys.modules[m] is not None]
print('loaded:', loaded)
sys.exit(rc)
'''


def run_without_matplotlib(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop('FLIGHT_SIM_DYNAMICS_DEBUG', None)
    return subprocess.run([sys.executable, '-c', WITHOUT_MATPLOTLIB, *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope='module')
def solved(tmp_path_factory) -> tuple[Path, list[subprocess.CompletedProcess]]:
    """A trajectory (``example``) and its solution as CSV and .npz, each made
    without matplotlib: (their folder, the ``solve`` runs)."""
    folder = tmp_path_factory.mktemp('without_matplotlib')
    r = run_without_matplotlib('example', 'general', '--rate', '10', '-o', 'traj.csv',
                               cwd=folder)
    assert r.returncode == 0, r.stderr
    return folder, [run_without_matplotlib('solve', 'traj.csv', '-o', output, cwd=folder)
                    for output in ('out.csv', 'out.npz')]


@pytest.mark.ros
def test_library_node_and_solve_need_no_matplotlib(solved):
    folder, runs = solved
    for r, output in zip(runs, ('out.csv', 'out.npz')):
        assert r.returncode == 0 and r.stderr == '', r.stderr
        assert r.stdout.strip() == 'loaded: []'
        assert (folder / output).stat().st_size > 1000


@pytest.mark.ros
@pytest.mark.parametrize('argv', [
    ['plot', 'out.csv', '-o', 'fig.png'],
    ['plot', 'out.npz', '-o', 'fig.svg'],
    ['workspace', '-o', 'fig.png'],
    ['animate', 'out.csv', '-o', 'motion.gif'],
    ['animate', 'out.npz', '-o', 'still.png'],
])
def test_drawing_without_matplotlib_is_one_error_line(solved, tmp_path, argv):
    folder, runs = solved
    assert all(r.returncode == 0 for r in runs)
    for name in ('out.csv', 'out.npz'):
        shutil.copy(folder / name, tmp_path / name)
    r = run_without_matplotlib(*argv, cwd=tmp_path)
    assert r.returncode == 2
    # one error line naming the command and the extra to install, no traceback
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith('error:'), r.stderr
    assert argv[0] in lines[0] and 'matplotlib' in lines[0] and '[plot]' in lines[0]
    assert not (tmp_path / argv[-1]).exists()


def test_packaging_declares_matplotlib_optional():
    """setup.py: not in install_requires, the extra 'plot' (and 'test');
    package.xml: no exec_depend on it; requirements.txt (the README's
    scripts install it) still pins it."""
    tree = ast.parse((ROOT / 'setup.py').read_text())
    call = next(node for node in ast.walk(tree)
                if isinstance(node, ast.Call) and getattr(node.func, 'id', '') == 'setup')
    kwargs = {k.arg: ast.literal_eval(k.value) for k in call.keywords
              if k.arg in ('install_requires', 'extras_require')}
    assert not any(r.startswith('matplotlib') for r in kwargs['install_requires'])
    assert kwargs['extras_require']['plot'] == ['matplotlib']
    assert 'matplotlib' in kwargs['extras_require']['test']
    xml = (ROOT / 'package.xml').read_text()
    assert '<exec_depend>python3-matplotlib</exec_depend>' not in xml
    assert '<test_depend>python3-matplotlib</test_depend>' in xml
    pins = (ROOT / 'requirements.txt').read_text().split()
    assert any(p.startswith('matplotlib==') for p in pins)
