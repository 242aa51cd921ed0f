"""The switch between each machine's compiled kernel (docs/kernel.md) and its
Python code, the reference it is tested against. A machine's kernel is used
where built unless FSD_KERNEL=0 or :func:`use_kernel` (False) asks for the
Python code; the switch is one for every machine.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from typing import Iterator

#: FSD_KERNEL=0: the Python code even when a kernel is built (subprocesses inherit it).
_choice = os.environ.get('FSD_KERNEL', '1')
if _choice not in ('0', '1'):
    raise ImportError(f'FSD_KERNEL={_choice!r}: expected 0 (the Python code) or 1 (the kernel)')
_wanted = _choice == '1'


def wanted() -> bool:
    """True unless FSD_KERNEL=0 or :func:`use_kernel` (False) asks for the
    Python code: every machine's compiled kernel is then used where built.
    """
    return _wanted


@contextmanager
def use_kernel(on: bool) -> Iterator[None]:
    """Within the block, solve with each machine's kernel (True, where built)
    or with the Python reference code (False).
    """
    global _wanted
    before = _wanted
    _wanted = bool(on)
    try:
        yield
    finally:
        _wanted = before
