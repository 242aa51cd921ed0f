"""The 3-DOF machine's status rule (:func:`sample_status`), written once for
floats and arrays alike, its ``limit`` by the usages of :mod:`.limits`;
``kernel.c`` transcribes it. The statuses and
their order are :mod:`flight_sim_dynamics.core.status`'s.
"""
from __future__ import annotations

from typing import Iterable, Sequence

from ...core.status import RESULTS_NOT_FINITE, SEVERITY, Status
from ...core.vectors import Scalar, backend
from .kinematics import LOOP_REASONS, LOOPS
from .limits import KINDS, LABELS, leg_usages
from .model import Limits


def condition_2x2(a: tuple, b: tuple, xp) -> object:
    """Exact 2-norm condition number of the 2x2 matrix [a b]: sigma_max^2 / |det|."""
    f2 = a[0] * a[0] + a[1] * a[1] + b[0] * b[0] + b[1] * b[1]
    det = xp.abs(a[0] * b[1] - a[1] * b[0])
    sigma_max2 = 0.5 * (f2 + xp.sqrt(xp.clip0((f2 - 2.0 * det) * (f2 + 2.0 * det))))
    return sigma_max2 / det


_FLOATS = backend(False)
_INPUTS = ('q', 'qd', 'qdd')
_COORDINATES = ('surge', 'heave', 'roll')


def first_bad_input(values: Sequence[Scalar], xp) -> Scalar:
    """Index (0-8) of the first non-finite of the 9 components of q, qd, qdd, or -1."""
    index = -1
    for i in range(len(values) - 1, -1, -1):
        index = xp.where(xp.isfinite(values[i]), index, i)
    return index


def first_open_loop(valid: dict, xp) -> Scalar:
    """Index in :data:`.kinematics.LOOPS` of the first loop of eq. (7) that
    cannot close, or -1.
    """
    index = -1
    for i in range(len(LOOPS) - 1, -1, -1):
        index = xp.where(valid[LOOPS[i]], index, i)
    return index


def all_finite(numbers: Iterable[Scalar], xp) -> Scalar:
    """True where every one of the numbers is finite."""
    finite = True
    for value in numbers:
        finite = finite & xp.isfinite(value)
    return finite


def sample_status(limits: Limits, xp, bad_input: Scalar = -1, open_loop: Scalar = -1,
                  finite: Scalar = True, kin: Scalar = 0.0, jac: Scalar = 0.0,
                  stroke: Sequence[Scalar] = (0.0,) * 3, rate: Sequence[Scalar] = (0.0,) * 3,
                  force: Sequence[Scalar] = (0.0,) * 3) -> tuple[Scalar, Scalar]:
    """Return the status rule's (code, info): the severity of the first that applies.

    1. invalid_input, info = the first non-finite input (nothing computed);
    2. unreachable, info = the first loop that cannot close;
    3. near_singular (a condition over its limit or NaN), info = 1, or 0 at an
       exact singularity (some result not finite: set to 0);
    4. invalid_input, info = :data:`RESULTS_NOT_FINITE` (results overflow);
    5. limit (a stroke, speed or force limit exceeded: a usage of
       :func:`.limits.leg_usages` above 1); 6. ok.
    """
    near = xp.logical_not((kin <= limits.max_kinematic_condition)
                          & (jac <= limits.max_jacobian_condition))
    over = False
    for usage in leg_usages(limits, xp, stroke, rate, force):
        over = over | (usage > 1.0)
    code = xp.where(over, SEVERITY[Status.LIMIT], SEVERITY[Status.OK])
    info = 0
    overflow = xp.logical_not(finite)
    code = xp.where(overflow, SEVERITY[Status.INVALID_INPUT], code)
    info = xp.where(overflow, RESULTS_NOT_FINITE, info)
    code = xp.where(near, SEVERITY[Status.NEAR_SINGULAR], code)
    info = xp.where(near, xp.where(finite, 1, 0), info)
    code = xp.where(open_loop >= 0, SEVERITY[Status.UNREACHABLE], code)
    info = xp.where(open_loop >= 0, open_loop, info)
    code = xp.where(bad_input >= 0, SEVERITY[Status.INVALID_INPUT], code)
    info = xp.where(bad_input >= 0, bad_input, info)
    return code, info


def describe(status: Status, info: int, limits: Limits, inputs: Sequence[Sequence[float]],
             stroke: Sequence[float], rate: Sequence[float], force: Sequence[float],
             kin: float, jac: float) -> str:
    """Why one sample has its status ('' for ok), from :func:`sample_status`'s info."""
    info = int(info)
    if status is Status.INVALID_INPUT:
        if info == RESULTS_NOT_FINITE:
            return 'results are not finite: input too large'
        value = inputs[info // 3][info % 3]
        return (f'{_INPUTS[info // 3]}[{info % 3}] ({_COORDINATES[info % 3]}) '
                f'is not finite ({value})')
    if status is Status.UNREACHABLE:
        loop = LOOPS[info]
        return f'loop {loop}: {LOOP_REASONS[loop]}'
    out = []
    if status is Status.NEAR_SINGULAR:
        if not info:
            return 'exact singularity: non-finite results set to 0'
        if not kin <= limits.max_kinematic_condition:
            out.append(f'kinematic condition {kin:.3g} > {limits.max_kinematic_condition:g}')
        if not jac <= limits.max_jacobian_condition:
            out.append(f'actuator Jacobian condition {jac:.3g} > '
                       f'{limits.max_jacobian_condition:g}')
    elif status is Status.LIMIT:     # the usages above 1, named with their values
        usages = leg_usages(limits, _FLOATS, [float(v) for v in stroke],
                            [float(v) for v in rate], [float(v) for v in force])
        for k, usage in enumerate(usages):
            if not usage > 1.0:
                continue
            i, kind = divmod(k, len(KINDS))
            leg = LABELS[i]
            if KINDS[kind] == 'stroke':
                out.append(f'stroke {leg} {stroke[i]:.4g} m outside '
                           f'[{limits.stroke_min:g}, {limits.stroke_max:g}] m')
            elif KINDS[kind] == 'speed':
                out.append(f'speed {leg} {abs(rate[i]):.4g} m/s > {limits.max_speed:g} m/s')
            else:
                out.append(f'force {leg} {abs(force[i]):.4g} N > {limits.max_force:g} N')
    return '; '.join(out)
