"""Lint, as ament packages have it (ament_flake8, ament_pep257): ruff with the
rules and exceptions of ruff.toml over the package, its tests, benchmarks and
scripts. ruff is pinned in requirements-test.txt."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.ros
def test_ruff_finds_nothing():
    out = subprocess.run([sys.executable, '-m', 'ruff', 'check', '--no-cache',
                          '--output-format', 'concise', '.'],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert 'No module named ruff' not in out.stderr, (
        'ruff is not installed: pip install -r requirements-test.txt')
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_lint_covers_docstrings_and_pyflakes():
    """The configuration keeps the docstring (D) and pyflakes (F) families on."""
    text = (ROOT / 'ruff.toml').read_text()
    for family in ('"E"', '"F"', '"W"', '"D"'):
        assert family in text.split('select', 1)[1].split(']', 1)[0], family
