"""The hexapod's compiled solve (``kernel.c`` here, built as ``_kernel``;
docs/kernel.md): (S1)-(S23) and the status rule of :mod:`.solver` in C, one
sample or a batch; and the twin's RK4 loop (:func:`integrate_rows`).
:mod:`.solver` and the twin use it when it is built, unless FSD_KERNEL=0 or
:func:`flight_sim_dynamics.core.kernel.use_kernel` (False) asks for the numpy
code, the reference it is tested against. The layouts are declared once,
in the C source; this module checks them against the package's own lists.
"""
from __future__ import annotations

import threading
from operator import attrgetter
from types import ModuleType

import numpy as np

from ...core import kernel as core_kernel
from ...core.effects import EFFECT_NAMES
from ...core.status import BY_SEVERITY, RESULTS_NOT_FINITE, Status
from .model import (MAX_SOLVED_CONDITION, MIN_LENGTH, U_JOINT_TOLERANCE, UNREACHABLE_REASONS,
                    LegBody, RigidBody, StewartModel)

try:
    from . import _kernel
except ImportError as exc:      # not built (no compiler at install time)
    _kernel = None
    IMPORT_ERROR: str | None = str(exc)
else:
    IMPORT_ERROR = None

#: A result row's fields, as the solver reads them: the StewartSolution's
#: arrays and condition, the status code and its info, the pose solved for.
ROW_FIELDS = ('length', 'stroke', 'rate', 'acceleration', 'force', 'power', 'joints',
              'joint_rates', 'joint_accelerations', 'spherical_angles', 'jacobian',
              'twist_jacobian', 'jacobian_condition', 'status', 'info', 'pose')


def contract_problems(module: ModuleType) -> list[str]:
    """How a built kernel's declarations disagree with this package ([] if not)."""
    problems = []
    for what, theirs, ours in (('effects', set(module.EFFECTS), set(EFFECT_NAMES)),
                               ('statuses', tuple(module.STATUS),
                                tuple(s.value for s in BY_SEVERITY)),
                               ('unreachable reasons', tuple(module.UNREACHABLE),
                                UNREACHABLE_REASONS),
                              ('result row fields', set(module.OUT), set(ROW_FIELDS))):
        if theirs != ours:
            problems.append(f'{what}: the kernel has {theirs}, the Python code {ours}')
    for name, theirs, ours in (('RESULTS_NOT_FINITE', module.RESULTS_NOT_FINITE,
                                RESULTS_NOT_FINITE),
                               ('U_JOINT_TOLERANCE', module.U_JOINT_TOLERANCE,
                                U_JOINT_TOLERANCE),
                               ('MIN_LENGTH', module.MIN_LENGTH, MIN_LENGTH),
                               ('MAX_SOLVED_CONDITION', module.MAX_SOLVED_CONDITION,
                                MAX_SOLVED_CONDITION)):
        if theirs != ours:
            problems.append(f'{name}: the kernel has {theirs}, the Python code {ours}')
    return problems + core_kernel.layout_problems((
        ('PACKED', module.PACKED, module.P_SIZE),
        ('RIGID_ROW', module.RIGID_ROW, module.RIGID_SIZE),
        ('LEG_ROW', module.LEG_ROW, module.LEG_SIZE),
        ('OUT', module.OUT, module.OUT_SIZE)))


_kernel, IMPORT_ERROR = core_kernel.checked(f'{__package__}._kernel', _kernel, IMPORT_ERROR,
                                            contract_problems)

if _kernel is not None:
    OUT_SIZE = _kernel.OUT_SIZE
    #: Result row layout: field -> (offset, size).
    OUT = dict(_kernel.OUT)
    O_COND, O_STATUS, O_INFO, O_SPHERICAL, O_TWIST_JACOBIAN = (
        OUT[name][0] for name in ('jacobian_condition', 'status', 'info', 'spherical_angles',
                                  'twist_jacobian'))
    #: Status of each kernel code.
    STATUS_BY_CODE = tuple(Status(name) for name in _kernel.STATUS)
    solve_one = _kernel.solve       # (params, bits, out, q, qd, qdd) -> (code, info, cond)
    #: A row's jacobian_condition that solve left to :func:`conditions`.
    NOT_COMPUTED = _kernel.NOT_COMPUTED
else:   # the numpy code runs without any of them
    OUT = {}


def _packed(value: object, rows: dict) -> np.ndarray:
    """A body as the kernel reads it (``rows``: RIGID_ROW or LEG_ROW)."""
    out = np.zeros(sum(n for _, n in rows.values()))
    for name, (offset, size) in rows.items():
        out[offset:offset + size] = np.ravel(getattr(value, name))
    return out


def pack_model(model: StewartModel) -> np.ndarray:
    """The model as the kernel reads it: each attribute path of PACKED at its
    offset (bodies by RIGID_ROW, LEG_ROW; a limit that is off as +inf).
    """
    packed = np.zeros(_kernel.P_SIZE)
    for path, (offset, size) in _kernel.PACKED.items():
        value = attrgetter(path)(model)
        if isinstance(value, RigidBody):
            value = _packed(value, _kernel.RIGID_ROW)
        elif isinstance(value, LegBody):
            value = _packed(value, _kernel.LEG_ROW)
        elif value is None:
            value = np.inf
        value = np.ravel(np.asarray(value, dtype=np.float64))
        if value.shape != (size,):
            raise ValueError(f'model.{path} has {value.size} numbers, the kernel reads {size}')
        packed[offset:offset + size] = value
    packed.flags.writeable = False
    return packed


def effect_bits(model: StewartModel) -> int:
    """The scene's effects as the kernel's bit set (EFFECTS)."""
    return sum(bit for name, bit in _kernel.EFFECTS.items() if getattr(model.effects, name))


_glue = core_kernel.Glue(_kernel, pack_model, effect_bits)
available, enabled, prepared = _glue.available, _glue.enabled, _glue.prepared
solve_rows, integrate_rows = _glue.solve_rows, _glue.integrate_rows


def joint_angles(model: StewartModel, rows: np.ndarray) -> None:
    """Fills in place the joint angles (the U-joints' in ``joints``, the
    ``spherical_angles``) of the result rows of ``model`` that solve_batch left
    to this call: it computes them only where a joint-angle limit is on (they
    are a third of its cost), from the row's pose and J. One call at a time: a
    row half filled by one is not taken for done by another.
    """
    if rows.ndim == 1 and rows[O_SPHERICAL] != NOT_COMPUTED:     # a single solve's
        return
    params, _ = prepared(model)
    with _FILLING:
        _kernel.joint_angles(params, rows.reshape(-1, OUT_SIZE))


_FILLING = threading.Lock()


def conditions(rows: np.ndarray) -> np.ndarray:
    """The condition of J of every result row, (N,) for (N, OUT_SIZE) rows:
    the row's own where solve computed it, else the kernel's (the same Jacobi
    sweeps solve runs).
    """
    if rows.ndim == 1:                  # a single solve's row
        cond = np.array(rows[O_COND])
        if cond != NOT_COMPUTED:
            return cond
        _kernel.conditions(rows[O_TWIST_JACOBIAN:O_TWIST_JACOBIAN + 36], cond.reshape(1))
        return cond
    cond = rows[..., O_COND].copy()
    todo = np.flatnonzero(cond.reshape(-1) == NOT_COMPUTED)
    if todo.size:
        offset, size = OUT['twist_jacobian']
        jacobians = np.ascontiguousarray(rows.reshape(-1, OUT_SIZE)[todo, offset:offset + size])
        found = np.empty(todo.size)
        _kernel.conditions(jacobians, found)
        cond.reshape(-1)[todo] = found
    return cond
