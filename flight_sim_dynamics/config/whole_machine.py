"""The check of a whole machine, every machine's, made wherever a model is
built from parameters (:func:`.machine_files.model_of_values`): a file's
``load_model``, the node's configure and each of its runtime parameter sets.

The home pose (q = 0, at rest) must solve ``ok`` or ``limit`` with finite
numbers. A home that solves ``near_singular`` (joints at one point, collinear,
two identical legs, legs in the base plane: the forces there are 0 N or
meaningless), ``unreachable`` or ``invalid_input`` is refused, as is a
non-finite result. A home beyond a stroke, speed or force limit is accepted:
the limits are the user's to choose, and the status says so at every solve.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Collection, Mapping

import numpy as np

from ..core.machine import Machine
from ..core.status import Status
from ..machines.api import machine_of, solve
from .errors import ParameterError

#: Statuses of the home pose that refuse the model.
REFUSED = frozenset({Status.NEAR_SINGULAR, Status.UNREACHABLE, Status.INVALID_INPUT})


def home_problem(model: Any) -> str | None:
    """Why the home pose of ``model`` makes it no machine (None: it solves
    ``ok`` or ``limit``, every number finite, or its machine has no solve).
    """
    machine = machine_of(model)
    if machine.solve is None:       # a machine that solves nothing (a workspace survey's)
        return None
    zero = np.zeros(machine.dof)
    sol = solve(model, zero, zero, zero)
    status = Status(sol.status)
    if status in REFUSED:
        return (f'the home pose (q = 0, at rest) solves {status}: {sol.detail}; '
                'a machine must be regular at home')
    bad = [f.name for f in dataclasses.fields(sol)
           if isinstance(value := getattr(sol, f.name), (float, np.ndarray))
           and np.asarray(value).dtype.kind == 'f' and not np.all(np.isfinite(value))]
    if bad:
        return f"the home pose (q = 0, at rest) solves with non-finite {', '.join(bad)}"
    return None


def blamed(machine: Machine, changed: Collection[str]) -> tuple[str, list[str]]:
    """(the key a refused home names, the parameters it is blamed on): those of
    the machine's :attr:`~.Machine.home_parameters` (geometry, singularity
    thresholds) among ``changed`` (a file's own values, a set's), else every
    changed one; one of them: its name, several: the group of the first
    (``geometry``).
    """
    culprits = ([k for k in machine.home_parameters if k in changed]
                or sorted(changed) or list(machine.home_parameters))
    if len(culprits) == 1:
        return culprits[0], culprits
    return culprits[0].split('.')[0], culprits


def check_home(model: Any, changed: Collection[str], values: Mapping[str, Any],
               source: str | None = None) -> None:
    """ParameterError unless the home pose of ``model`` (built from ``values``,
    ``changed`` the names given rather than defaulted) solves (:func:`home_problem`);
    the error names :func:`blamed`'s key and ``source`` (a file, the node's
    parameters).
    """
    problem = home_problem(model)
    if problem is None:
        return
    key, culprits = blamed(machine_of(model), changed)
    value = values.get(key) if key in values else culprits
    where = f' in {source}' if source else ''
    given = '' if culprits == [key] else f"; given: {', '.join(culprits)}"
    raise ParameterError(key, value, f'{problem}{given}{where}')
