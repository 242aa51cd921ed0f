"""The command line's progress lines on standard error: ``<command>: <output>:
[<stage>: ]k/n <unit> (p%, t s)`` at each tenth and at least every :data:`PROGRESS_SECONDS`.
"""
from __future__ import annotations

import time
from typing import TextIO

PROGRESS_SECONDS = 5.0


class Progress:
    """``<command>: <output>: k/n <unit>`` at each tenth and at least every PROGRESS_SECONDS."""

    def __init__(self, total: int, output: str, stream: TextIO, command: str = 'animate',
                 unit: str = 'frames') -> None:
        self.total, self.output, self.stream = total, output, stream
        self.command, self.unit = command, unit
        self.step = max(1, total // 10)
        self.start = self.last = time.monotonic()

    def done(self, k: int, stage: str = '') -> None:
        """``k`` of the total done (of ``stage``, named in the line, when not '')."""
        now = time.monotonic()
        if k % self.step and k != self.total and now - self.last < PROGRESS_SECONDS:
            return
        self.last = now
        where = f'{stage}: ' if stage else ''
        print(f'{self.command}: {self.output}: {where}{k}/{self.total} {self.unit} '
              f'({100 * k // max(self.total, 1)}%, {now - self.start:.1f} s)', file=self.stream,
              flush=True)
