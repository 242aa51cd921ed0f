"""The README's Python code blocks run verbatim (a newcomer copies them)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / 'README.md'
BLOCKS = re.findall(r'```python\n(.*?)```', README.read_text(), re.S)


def test_the_readme_has_python_blocks():
    assert BLOCKS, 'no ```python block found in README.md'


@pytest.mark.parametrize('index', range(len(BLOCKS)))
def test_readme_python_block_runs(index, capsys, tmp_path, monkeypatch):
    """From any folder, not only the repository root."""
    monkeypatch.chdir(tmp_path)
    exec(compile(BLOCKS[index], f'README.md python block {index + 1}', 'exec'), {})
    assert 'ok' in capsys.readouterr().out


def test_no_readme_command_writes_over_a_tracked_file():
    """A newcomer runs the README's commands in the checkout: none of their
    outputs (-o PATH) may replace a file of the project."""
    import subprocess
    listed = subprocess.run(['git', 'ls-files'], cwd=README.parent, capture_output=True,
                            text=True, timeout=60)
    if listed.returncode != 0:
        pytest.skip('not a git checkout')
    outputs = set(re.findall(r'(?:^|\s)(?:-o|--output)\s+([^\s`]+)', README.read_text()))
    assert outputs, 'no -o in the README'
    assert not outputs & set(listed.stdout.splitlines())
