"""The limiter between the washout and the machine (placeholder: ``none`` only).

Contract (flight_sim_dynamics.cueing.planner calls it): ``make_limiter(model,
params) -> limiter`` with ``reset()`` and ``step(q, qd, qdd) -> Limited`` (one
output sample, machine coordinates). :data:`LIMITER_SPECS`: the limiter's own
parameters (``cueing.<name>``); :mod:`.params` reads them (so this module must
not import :mod:`.params`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.parameter_spec import ParamSpec

#: The limiter's keys of the ``cueing`` group (names ``cueing.<...>``, required=False).
LIMITER_SPECS: tuple[ParamSpec, ...] = ()


@dataclass(frozen=True)
class Limited:
    """One sample as the limiter lets it through: q, qd, qdd (machine
    coordinates); ``given_up`` in [0, 1] (0: nothing); ``limit`` the limit that
    made it ('' when none).
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    given_up: float = 0.0
    limit: str = ''


class PassThrough:
    """``limiter: none``: the washout's sample as it is."""

    def reset(self) -> None:
        """Nothing to forget."""

    def step(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> Limited:
        return Limited(q, qd, qdd)


def make_limiter(model: Any, params: Any) -> PassThrough:
    """The limiter ``params.limiter`` names for ``model``."""
    return PassThrough()
