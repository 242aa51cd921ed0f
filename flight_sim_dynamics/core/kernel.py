"""The switch between each machine's compiled kernel (docs/kernel.md) and its
Python code, the reference it is tested against. A machine's kernel is used
where built unless FSD_KERNEL=0 or :func:`use_kernel` (False) asks for the
Python code; the switch is one for every machine.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from types import ModuleType
from typing import Callable, Iterable, Iterator

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


def layout_problems(layouts: Iterable[tuple[str, dict, int]]) -> list[str]:
    """Each (name, {field: (offset, size)}, doubles) a kernel exports must
    cover its doubles exactly once, field after field ([] if all do).
    """
    problems = []
    for name, table, size in layouts:
        spans = sorted(table.values())
        if [o for o, _ in spans] != [0] + [o + n for o, n in spans[:-1]] or sum(
                n for _, n in spans) != size:
            problems.append(f'{name} does not cover its {size} doubles exactly once')
    return problems


def checked(name: str, module: ModuleType | None, import_error: str | None,
            contract_problems: Callable[[ModuleType], list[str]]
            ) -> tuple[ModuleType | None, str | None]:
    """A machine's built kernel ``name`` (its module, or None and why not) if its
    declarations agree with the package's (``contract_problems``). ImportError
    for a kernel built from another kernel.c (unless FSD_KERNEL=0), and for no
    kernel with FSD_REQUIRE_KERNEL=1 (CI, benchmarks).
    """
    try:
        problems = contract_problems(module) if module is not None else []
    except AttributeError as exc:       # built before the kernel exported its declarations
        problems = [str(exc)]
    if problems:
        import_error = (f'{name} was built from another version of kernel.c ('
                        + '; '.join(problems) + '); rebuild it')
        module = None
        if os.environ.get('FSD_KERNEL') != '0':
            raise ImportError(import_error + ', or set FSD_KERNEL=0 to use the Python code')
    if module is None and os.environ.get('FSD_REQUIRE_KERNEL') == '1':
        raise ImportError(f'{name} is required (FSD_REQUIRE_KERNEL=1) but cannot be imported: '
                          f'{import_error}; build it with `python setup.py build_ext --inplace` '
                          'or `pip install .`')
    return module, import_error
