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

import numpy as np

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


def row_view(rows: np.ndarray, part: slice | int,
             shape: tuple[int, ...] | None = None) -> np.ndarray:
    """A field of kernel result row(s): ``rows[..., part]``, reshaped to
    ``rows.shape[:-1] + shape`` when a shape is given.
    """
    value = rows[..., part]
    return value if shape is None else value.reshape(rows.shape[:-1] + shape)


class Kept:
    """A field of a kernel solution made on first access and kept in the
    instance (functools.cached_property without its lock): a view of its result
    row(s) (``rows[..., part]``, reshaped to ``rows.shape[:-1] + shape`` when a
    shape is given), or ``compute(solution)``.
    """

    def __init__(self, compute: Callable[[object], object] | None = None, *,
                 part: slice | int | None = None, shape: tuple[int, ...] | None = None) -> None:
        self.compute, self.part, self.shape = compute, part, shape
        self.name = ''

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, sol: object | None, owner: type | None = None) -> object:
        if sol is None:
            return self
        if self.compute is None:
            value = row_view(sol.__dict__['_rows'], self.part, self.shape)
        else:
            value = self.compute(sol)
        sol.__dict__[self.name] = value
        return value


class Glue:
    """What every machine's kernel module does with its built ``_kernel`` (None:
    not built), written once: whether it runs, the model packed once and kept
    on the model, and the batch and RK4 calls that take a packed model.
    ``pack_model(model) -> ndarray`` and ``effect_bits(model) -> int`` are the
    machine's (the layouts are its kernel's).
    """

    def __init__(self, module: ModuleType | None, pack_model: Callable[[object], object],
                 effect_bits: Callable[[object], int]) -> None:
        self.module = module
        self._pack_model = pack_model
        self._effect_bits = effect_bits

    def available(self) -> bool:
        """True when the compiled kernel is built and importable."""
        return self.module is not None

    def enabled(self) -> bool:
        """True when the machine's solve and solve_batch use the compiled kernel
        (built, and :func:`wanted`).
        """
        return self.module is not None and _wanted

    def prepared(self, model: object) -> tuple:
        """(packed model, effect bits), computed once per model and kept on it."""
        cached = model.__dict__.get('_kernel_input')
        if cached is None:
            cached = (self._pack_model(model), self._effect_bits(model))
            object.__setattr__(model, '_kernel_input', cached)
        return cached

    def solve_rows(self, model: object, q: np.ndarray, qd: np.ndarray,
                   qdd: np.ndarray) -> np.ndarray:
        """N samples ((N, dof) float64 arrays) through the kernel: (N, OUT_SIZE) rows."""
        params, bits = self.prepared(model)
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (q, qd, qdd)]
        out = np.empty((arrays[0].shape[0], self.module.OUT_SIZE))
        self.module.solve_batch(params, bits, *arrays, out)
        return out

    def integrate_rows(self, model: object, law: tuple, step: float, k0: int, steps: int,
                       rows: tuple) -> int:
        """RK4 of :func:`flight_sim_dynamics.core.simulation.integrate` in the
        kernel, rows k0 to steps: ``law`` the fields of
        :class:`flight_sim_dynamics.core.servo.TabulatedLaw` (``tables()``),
        ``rows`` = (q, qd, qdd, force), (steps + 1, dof) C-contiguous float64, row
        k0 set. Returns the first row whose step it did not complete (steps + 1:
        all); a stage the kernel leaves (a stop, a condition it cannot bound) is
        the Python code's.
        """
        params, bits = self.prepared(model)
        return self.module.integrate(params, bits, *law, step, k0, steps, *rows)
