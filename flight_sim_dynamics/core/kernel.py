"""The compiled kernel: the solver's scalar path (eq. 5-23) as straight-line C.

``src/kernel.c`` is a line-by-line transcription of :mod:`.kinematics`,
:mod:`.dynamics` and the status rules of :mod:`.solver`, built as the
extension module ``flight_sim_dynamics.core._kernel`` when the package is
installed (``pip install .``, ``colcon build``; ``python setup.py build_ext
--inplace`` for the source tree). :func:`.solver.solve` and
:func:`.solver.solve_batch` use it when it is there and fall back to the
Python code (the reference: same equations, same results to round-off,
slower) when it is not; ``use_kernel(False)`` forces the Python code, and so
does FSD_KERNEL=0 in the environment.

The model goes to C once, packed into an array of doubles by
:func:`pack_model` (cached on the model), with the scene's effects as a bit
set (:func:`effect_bits`). One solve fills a row of ``OUT_SIZE`` doubles
whose layout is :data:`OUT`.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Iterator

import numpy as np

from .model import BODY_NAMES, GEOMETRY_KEYS, Model

try:
    from . import _kernel
except ImportError as exc:      # not built (no compiler at install time)
    _kernel = None
    IMPORT_ERROR: str | None = str(exc)
else:
    IMPORT_ERROR = None

#: Set FSD_REQUIRE_KERNEL=1 to make a missing kernel an error at import (CI, benchmarks).
if _kernel is None and os.environ.get('FSD_REQUIRE_KERNEL') == '1':
    raise ImportError(f'flight_sim_dynamics.core._kernel is required (FSD_REQUIRE_KERNEL=1) but '
                      f'cannot be imported: {IMPORT_ERROR}; build it with '
                      f'`python setup.py build_ext --inplace` or `pip install .`')

#: Size of the packed model and of one result row (as in src/kernel.c).
P_SIZE = 189
OUT_SIZE = 68
BODY_SIZE = 13

#: Result row layout: field -> slice (src/kernel.c O_*).
OUT = {
    'length': slice(0, 3), 'stroke': slice(3, 6), 'rate': slice(6, 9),
    'acceleration': slice(9, 12), 'force': slice(12, 15), 'power': slice(15, 18),
    'joints': slice(18, 30), 'joint_rates': slice(30, 42),
    'joint_accelerations': slice(42, 54), 'jacobian': slice(54, 63),
}
O_BETA, O_KIN, O_JAC, O_STATUS, O_INFO = 63, 64, 65, 66, 67

#: Effects bits (src/kernel.c E_*); HAS_PAYLOAD: the model has a payload body.
EFFECT_BITS = {'gravity': 1, 'platform_inertia': 2, 'payload': 4, 'leg_inertia': 8,
               'crank_inertia': 16, 'velocity_products': 32, 'friction': 64}
HAS_PAYLOAD = 128

#: Loops in the order the kernel reports the first one that cannot close.
LOOPS = ('D', 'E', 'E2 on rod', 'A', 'B', 'C')

if _kernel is not None and (_kernel.P_SIZE, _kernel.OUT_SIZE, _kernel.BODY_SIZE) != (
        P_SIZE, OUT_SIZE, BODY_SIZE):
    raise ImportError('flight_sim_dynamics.core._kernel was built from another version of '
                      'src/kernel.c; rebuild it')

#: FSD_KERNEL=0 in the environment: solve with the Python code even when the
#: kernel is built (inherited by subprocesses: the node, the command line).
_choice = os.environ.get('FSD_KERNEL', '1')
if _choice not in ('0', '1'):
    raise ImportError(f'FSD_KERNEL={_choice!r}: expected 0 (the Python code) or 1 (the kernel)')
_enabled = _kernel is not None and _choice == '1'


def available() -> bool:
    """True when the compiled kernel is built and importable."""
    return _kernel is not None


def enabled() -> bool:
    """True when solve and solve_batch use the compiled kernel."""
    return _enabled


@contextmanager
def use_kernel(on: bool) -> Iterator[None]:
    """Within the block, solve with the kernel (True, if built) or with the
    Python reference code (False)."""
    global _enabled
    before = _enabled
    _enabled = bool(on) and _kernel is not None
    try:
        yield
    finally:
        _enabled = before


def _body_row(body) -> list[float]:
    return [float(body.mass), *map(float, body.com), *map(float, np.ravel(body.inertia))]


def pack_model(model: Model) -> np.ndarray:
    """The model as the kernel reads it (src/kernel.c P_*): geometry, leg
    lengths at zero stroke, central joint values, gravity, the 10 bodies and
    the payload (mass, centre of mass, inertia), friction, limits."""
    geom = model.geometry
    values: list[float] = [float(getattr(geom, key)) for key in GEOMETRY_KEYS]
    values += [float(x) for x in geom.L0]
    values += [float(x) for x in model.central.joint_zero]
    values.append(float(model.gravity))
    for name in BODY_NAMES:
        values += _body_row(model.bodies[name])
    values += _body_row(model.payload) if model.payload is not None else [0.0] * BODY_SIZE
    fr = model.friction
    values += [*map(float, fr.viscous), *map(float, fr.coulomb), float(fr.smoothing_velocity)]
    lim = model.limits
    values += [float(lim.stroke_min), float(lim.stroke_max), float(lim.max_speed),
               float(lim.max_force), float(lim.max_kinematic_condition),
               float(lim.max_jacobian_condition)]
    packed = np.array(values, dtype=np.float64)
    assert packed.shape == (P_SIZE,), packed.shape
    packed.flags.writeable = False
    return packed


def effect_bits(model: Model) -> int:
    """The scene's effects as the kernel's bit set."""
    bits = sum(bit for name, bit in EFFECT_BITS.items() if getattr(model.effects, name))
    return bits | (HAS_PAYLOAD if model.payload is not None else 0)


def prepared(model: Model) -> tuple[np.ndarray, int]:
    """(packed model, effect bits), computed once per model and kept on it."""
    cached = model.__dict__.get('_kernel_input')
    if cached is None:
        cached = (pack_model(model), effect_bits(model))
        object.__setattr__(model, '_kernel_input', cached)
    return cached


def solve_row(model: Model, q: tuple, qd: tuple, qdd: tuple) -> tuple[np.ndarray, tuple]:
    """One sample through the kernel: the result row and its scalars (status
    code, detail code, beta, kinematic condition, Jacobian condition)."""
    params, bits = prepared(model)
    out = np.empty(OUT_SIZE)
    return out, _kernel.solve(params, bits, out, *q, *qd, *qdd)


#: A batch at least twice this long is split across the usable cores (the
#: kernel releases the GIL); shorter ones run in the calling thread.
THREAD_MIN_SAMPLES = 4096
_pool: ThreadPoolExecutor | None = None


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:          # not Linux
        return max(1, os.cpu_count() or 1)


def solve_rows(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """N samples ((N, 3) float64 arrays) through the kernel: (N, OUT_SIZE) rows.
    Long batches run in as many threads as there are usable cores (each row is
    computed alone, so the result does not depend on the split)."""
    global _pool
    params, bits = prepared(model)
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (q, qd, qdd)]
    n = arrays[0].shape[0]
    out = np.empty((n, OUT_SIZE))
    parts = min(usable_cores(), n // THREAD_MIN_SAMPLES)
    if parts < 2:
        _kernel.solve_batch(params, bits, *arrays, out)
        return out
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=usable_cores(), thread_name_prefix='fsd-kernel')
    bounds = np.linspace(0, n, parts + 1).astype(int)
    jobs = [_pool.submit(_kernel.solve_batch, params, bits,
                         *(a[lo:hi] for a in arrays), out[lo:hi])
            for lo, hi in zip(bounds[:-1], bounds[1:])]
    for job in jobs:
        job.result()
    return out
