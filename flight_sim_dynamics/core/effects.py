"""Effects and scenes: simulate only what a scene calls for.

An :class:`Effects` set switches each physical effect on or off; a disabled
effect's terms are never computed:

================== ==========================================================
gravity            weight of every simulated body (eq. 19)
platform_inertia   inertia wrench of the platform (translation and rotation)
payload            the cab and occupants on the platform: an extra rigid body
                   (``payload.*`` parameters), weight and inertia
leg_inertia        inertia wrenches of the bodies of chains A, B, C
                   (cylinders, pistons and the rod A3G)
crank_inertia      inertia wrenches of cranks D and E
velocity_products  centrifugal and Coriolis terms (the velocity-product parts
                   of eq. 17 and 18); off = the forces of the same
                   accelerations from rest
friction           actuator friction: viscous plus Coulomb (smoothed by
                   tanh(rate / friction.smoothing_velocity)), per actuator
================== ==========================================================

A *scene* (``config/scenes/*.yaml``, :mod:`..config.scenes`) names every
effect true or false, with optional parameter overrides.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace


@dataclass(frozen=True)
class Effects:
    """Which physical effects the solver computes (defaults: the ``full``
    scene's, every weight, inertia and velocity product, no payload, no
    friction); the fields are :data:`EFFECT_NAMES`.
    """

    gravity: bool = True
    platform_inertia: bool = True
    payload: bool = False
    leg_inertia: bool = True
    crank_inertia: bool = True
    velocity_products: bool = True
    friction: bool = False

    @property
    def any_inertia(self) -> bool:
        """True when some inertia wrench is computed (accelerations are needed)."""
        return self.platform_inertia or self.payload or self.leg_inertia or self.crank_inertia

    def only(self, *names: str) -> 'Effects':
        """The effects set with exactly ``names`` enabled."""
        unknown = set(names) - set(EFFECT_NAMES)
        if unknown:
            raise ValueError(f"unknown effect(s): {', '.join(sorted(unknown))}")
        return Effects(**{name: name in names for name in EFFECT_NAMES})

    def without(self, *names: str) -> 'Effects':
        """The effects set with ``names`` disabled."""
        return replace(self, **{name: False for name in names})

    def enabled(self) -> tuple[str, ...]:
        """Names of the enabled effects."""
        return tuple(name for name in EFFECT_NAMES if getattr(self, name))


#: The effects, in the order of the fields of :class:`Effects` (declared there only).
EFFECT_NAMES = tuple(f.name for f in fields(Effects))
