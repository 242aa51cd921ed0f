"""The 3-DOF machine's compiled kernel (``kernel.c`` here, built as ``_kernel``;
docs/kernel.md): the solver's scalar path (eq. 5-23) and the twin's RK4 loop
in C. Used when built, else the Python code (the reference);
:func:`flight_sim_dynamics.core.kernel.use_kernel` (False) or FSD_KERNEL=0
forces the Python code. The layouts are declared once, in the C
source; this module checks them against the package's own lists.
"""
from __future__ import annotations

from operator import attrgetter
from types import ModuleType

import numpy as np

from ...core import kernel as core_kernel
from ...core.effects import EFFECT_NAMES
from ...core.status import RESULTS_NOT_FINITE, Status
from .kinematics import LOOPS
from .model import BODY_NAMES, Body, Model

try:
    from . import _kernel
except ImportError as exc:      # not built (no compiler at install time)
    _kernel = None
    IMPORT_ERROR: str | None = str(exc)
else:
    IMPORT_ERROR = None


def contract_problems(module: ModuleType) -> list[str]:
    """How a built kernel's declarations disagree with this package ([] if not)."""
    problems = []
    for what, theirs, ours in (('effects', set(module.EFFECTS), set(EFFECT_NAMES)),
                               ('bodies', set(module.BODIES), set(BODY_NAMES) | {'payload'}),
                               ('statuses', set(module.STATUS), {s.value for s in Status})):
        if theirs - ours or (ours - theirs and what != 'statuses'):
            problems.append(f'{what}: the kernel has {sorted(theirs - ours)} more and '
                            f'{sorted(ours - theirs)} fewer than the Python code')
    if tuple(module.LOOPS) != LOOPS:
        problems.append(f'loop order {module.LOOPS} != kinematics.LOOPS {LOOPS}')
    if module.RESULTS_NOT_FINITE != RESULTS_NOT_FINITE:
        problems.append('status.RESULTS_NOT_FINITE differs')
    return problems + core_kernel.layout_problems((
        ('PACKED', module.PACKED, module.P_SIZE),
        ('BODY_ROW', module.BODY_ROW, module.BODY_SIZE),
        ('OUT', module.OUT, module.OUT_SIZE)))


_kernel, IMPORT_ERROR = core_kernel.checked(f'{__package__}._kernel', _kernel, IMPORT_ERROR,
                                            contract_problems)

if _kernel is not None:
    P_SIZE, OUT_SIZE, BODY_SIZE = _kernel.P_SIZE, _kernel.OUT_SIZE, _kernel.BODY_SIZE
    PACKED, BODY_ROW, EFFECTS, HAS_PAYLOAD = (_kernel.PACKED, _kernel.BODY_ROW, _kernel.EFFECTS,
                                              _kernel.HAS_PAYLOAD)
    #: The kernel's order of the bodies in the packed model.
    BODIES = _kernel.BODIES
    #: Result row layout: field -> slice (one number: its offset).
    OUT = {name: slice(o, o + n) if n > 1 else o for name, (o, n) in _kernel.OUT.items()}
    O_BETA, O_KIN, O_JAC, O_STATUS, O_INFO = (OUT[name] for name in (
        'beta', 'kinematic_condition', 'jacobian_condition', 'status', 'info'))
    #: Status of each kernel code.
    STATUS_BY_CODE = tuple(Status(name) for name in _kernel.STATUS)
else:   # the Python code runs without any of them
    OUT = {}

def _body_row(body: Body | None) -> np.ndarray:
    """One body as the kernel reads it (:data:`BODY_ROW`); zeros for no body."""
    row = np.zeros(BODY_SIZE)
    if body is not None:
        for name, (offset, size) in BODY_ROW.items():
            row[offset:offset + size] = np.ravel(getattr(body, name))
    return row


def pack_model(model: Model) -> np.ndarray:
    """The model as the kernel reads it: each attribute path of :data:`PACKED`
    at its offset, the bodies in the order :data:`BODIES` (no payload: zeros).
    """
    packed = np.zeros(P_SIZE)
    for path, (offset, size) in PACKED.items():
        if path == 'bodies':
            value = np.concatenate([_body_row(model.payload if name == 'payload'
                                              else model.bodies[name]) for name in BODIES])
        else:
            value = np.ravel(np.asarray(attrgetter(path)(model), dtype=np.float64))
        if value.shape != (size,):
            raise ValueError(f'model.{path} has {value.size} numbers, the kernel reads {size}')
        packed[offset:offset + size] = value
    packed.flags.writeable = False
    return packed


def effect_bits(model: Model) -> int:
    """The scene's effects as the kernel's bit set (:data:`EFFECTS`)."""
    bits = sum(bit for name, bit in EFFECTS.items() if getattr(model.effects, name))
    return bits | (HAS_PAYLOAD if model.payload is not None else 0)


def solve_row(model: Model, q: tuple, qd: tuple, qdd: tuple) -> tuple[np.ndarray, tuple]:
    """One sample through the kernel: the result row and its scalars (status
    code, detail code, beta, kinematic condition, Jacobian condition).
    """
    params, bits = prepared(model)
    out = np.empty(OUT_SIZE)
    return out, _kernel.solve(params, bits, out, q, qd, qdd)


def affine_row(model: Model, q: tuple, qd: tuple
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """The terms of f = M qdd + b at (q, qd) in one call: the row of solve(q, qd, 0), M, b
    and the row's scalars (as :func:`solve_row`).
    """
    params, bits = prepared(model)
    out, M, b = np.empty(OUT_SIZE), np.empty((3, 3)), np.empty(3)
    return out, M, b, _kernel.affine(params, bits, out, M, b, q, qd)


_glue = core_kernel.Glue(_kernel, pack_model, effect_bits)
available, enabled, prepared = _glue.available, _glue.enabled, _glue.prepared
solve_rows, integrate_rows = _glue.solve_rows, _glue.integrate_rows
