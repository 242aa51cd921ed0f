"""What every benchmark prints first, and its tables (markdown)."""
from __future__ import annotations

import datetime
import os
import platform
import subprocess
from pathlib import Path
from flight_sim_dynamics.cli.bench import table  # noqa: F401 - the benchmarks' tables

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

