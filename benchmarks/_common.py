"""What every benchmark prints first, and its tables (markdown)."""
from __future__ import annotations

import datetime
import os
import platform
import subprocess
from pathlib import Path
from typing import Sequence

ROOT = Path(__file__).resolve().parents[1]


def commit() -> str:
    git = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, text=True,
                         capture_output=True)
    return git.stdout.strip() or 'unknown'


def header(what: str) -> str:
    """``# date, commit, CPUs, load average, Python; what``."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    return (f'# {now}, commit {commit()}, {os.cpu_count()} CPUs, load average '
            f'{os.getloadavg()[0]:.2f}, Python {platform.python_version()}; {what}')


def table(columns: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ['| ' + ' | '.join(columns) + ' |',
             '|' + '|'.join([':---'] + ['---:'] * (len(columns) - 1)) + '|']
    return '\n'.join(lines + ['| ' + ' | '.join(map(str, row)) + ' |' for row in rows])
