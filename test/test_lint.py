"""Lint, as ament packages have it (ament_flake8, ament_pep257): ruff with the
rules and exceptions of ruff.toml over the package, its tests, benchmarks and
scripts. ruff is pinned in requirements-test.txt."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def lint_targets(root: Path) -> list[str]:
    """The Python files git tracks under ``root`` (a user's untracked scratch
    file is not the project's); the whole tree when it is not a git checkout."""
    try:
        listed = subprocess.run(['git', 'ls-files', '-z', '--', '*.py', '*.pyi'], cwd=root,
                                capture_output=True, timeout=60)
    except OSError:                     # no git
        return ['.']
    if listed.returncode != 0:
        return ['.']
    return [name for name in listed.stdout.decode().split('\0')
            if name and (root / name).is_file()]         # not the ones deleted but not staged


def run_ruff(root: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'ruff', 'check', '--no-cache',
                           '--output-format', 'concise', *lint_targets(root)],
                          cwd=root, capture_output=True, text=True, timeout=120)


@pytest.mark.ros
def test_ruff_finds_nothing():
    out = run_ruff(ROOT)
    assert 'No module named ruff' not in out.stderr, (
        'ruff is not installed: pip install -r requirements-test.txt')
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.ros
def test_an_untracked_scratch_file_is_not_linted(tmp_path):
    """A user's scratch .py in the checkout fails no test; outside git the
    whole tree is linted."""
    (tmp_path / 'ruff.toml').write_text((ROOT / 'ruff.toml').read_text())
    (tmp_path / 'tracked.py').write_text('"""A module."""\nX = 1\n')
    (tmp_path / 'scratch.py').write_text('import os\n')          # F401: unused import
    assert run_ruff(tmp_path).returncode == 1                   # not a checkout: all of it
    env = dict(os.environ, GIT_CONFIG_GLOBAL=os.devnull, GIT_CONFIG_NOSYSTEM='1')
    for args in (['init', '-q'], ['add', 'tracked.py']):
        subprocess.run(['git', *args], cwd=tmp_path, env=env, check=True, timeout=60)
    out = run_ruff(tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert lint_targets(tmp_path) == ['tracked.py']


def test_the_lint_covers_docstrings_and_pyflakes():
    """The configuration keeps the docstring (D) and pyflakes (F) families on."""
    text = (ROOT / 'ruff.toml').read_text()
    for family in ('"E"', '"F"', '"W"', '"D"'):
        assert family in text.split('select', 1)[1].split(']', 1)[0], family
