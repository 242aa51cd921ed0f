"""What every benchmark prints first, and its tables (markdown)."""
from __future__ import annotations

import datetime
import os
import platform
import subprocess
from pathlib import Path

from flight_sim_dynamics.cli.bench import table  # noqa: F401 - the benchmarks' tables

ROOT = Path(__file__).resolve().parents[1]


def header(what: str) -> str:
    """``# date, commit, CPUs, load average, Python; what``."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, text=True,
                            capture_output=True).stdout.strip() or 'unknown'
    return (f'# {now}, commit {commit}, {os.cpu_count()} CPUs, load average '
            f'{os.getloadavg()[0]:.2f}, Python {platform.python_version()}; {what}')

