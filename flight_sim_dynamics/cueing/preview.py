"""(L8) The preview of an offline run (docs/design/cueing_limiter.md): with the
whole vehicle log known, a gain ``g(t)`` in [0, 1] on the vehicle's motion,
planned before the limiter runs, lowered only around the moments the machine
cannot take at full gain and only as far as they need.

1. The washout of the (scaled) log, sample by sample; each sample's largest
   fitting gain ``k`` by the limiter's own acceptance (L2) on the machine's
   tightened model (:meth:`.InverseDynamicsLimiter.fitting_gain`).
2. ``g`` times the envelope of ``k`` (:func:`envelope`, ``MARGIN k`` where
   ``k < 1``): reached ``preview.lead`` s before each such moment (the
   washout's filters carry the motion before a moment into it), reached down
   to before that and back up from right after it at ``preview.slope`` per
   second.
3. The vehicle's motion scaled, ``u' = u₀ + g (u − u₀)`` (``u₀`` the first
   sample, the washout's rest): a constant ``g`` is the usual practice, every
   washout gain times ``g``; a varying one changes the washout's filters'
   response a little, so 1 to 3 are repeated, at most :data:`PASSES` times,
   until every sample fits.

The limiter then runs on the scaled log as always (its look-ahead, L7, off:
the preview replaces it): the guarantee stays the governor's.
"""
from __future__ import annotations

from typing import Callable, Iterable

import numpy as np
from scipy.ndimage import minimum_filter1d

from ..config.cueing import G

#: Passes of the preview at most (the last one's wishes still judged by the limiter).
PASSES = 4
#: The gain the preview plans at a moment, times that moment's fitting gain (a
#: little below it: the washout's filters answer a varying gain slightly off).
MARGIN = 0.99
#: Where the planner holds a non-finite first sample (Planner: the vehicle at rest).
REST = (0.0, 0.0, G, 0.0, 0.0, 0.0)


def envelope(k: np.ndarray, slope: float, lead: int) -> np.ndarray:
    """The largest ``g ≤ k`` (N,) that changes by at most ``slope`` per sample
    and is at each sample's ``k`` from ``lead`` samples before it:
    ``g[n] = min over m of k[m] + slope · d(n, m)``, ``d = max(0, m − n − lead)``
    for a moment ``m`` ahead of ``n``, ``n − m`` behind it.
    """
    # the minimum of k over [n, n + lead]
    held = minimum_filter1d(k, size=lead + 1, origin=-((lead + 1) // 2), mode='nearest')
    ramp = slope * np.arange(len(k))
    forward = np.minimum.accumulate(held - ramp) + ramp
    backward = (np.minimum.accumulate((held + ramp)[::-1]) - ramp[::-1])[::-1]
    return np.minimum(forward, backward)


def scaled(inputs: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The vehicle's motion ``inputs`` (N, 6: f, omega) scaled by ``g`` (N,)
    about its first sample (the washout's rest; :data:`REST` if not finite);
    the samples at ``g = 1`` as they are, bit for bit.
    """
    rest = inputs[0] if np.isfinite(inputs[0]).all() else np.array(REST)
    return np.where((g == 1.0)[:, None], inputs, rest + g[:, None] * (inputs - rest))


def gain_profile(inputs: np.ndarray,
                 wishes: Callable[[np.ndarray], Iterable[tuple[list, bool | None]]],
                 fitting_gain: Callable[[list, list, list], tuple[float, str]],
                 dof: int, rate: float, slope: float, lead: float,
                 progress: Callable[[int, int], None] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(L8) The preview's gain (N,) on ``inputs`` (N, 6) and the limit that set
    it at each sample ('' where it is 1; else the limit of the nearest sample
    that needed it). ``wishes(inputs)``: the washout's samples (q, qd, qdd one
    list each), from rest, each with whether the limiter accepts it at gain 1
    if judged already (else None); ``fitting_gain``: the limiter's judge; ``slope`` 1/s,
    ``lead`` s; ``progress(pass, samples)``: called now and then (passes from 1).
    """
    n = len(inputs)
    g = np.ones(n)
    needed = np.zeros(n, dtype=bool)
    names = np.full(n, '', dtype=object)
    current = inputs
    every = max(1, n // 100)
    for i in range(1, PASSES + 1):
        k = np.ones(n)
        for m, (w, fits) in enumerate(wishes(current)):
            if not fits:            # fits: k = 1
                k[m], limit = fitting_gain(w[:dof], w[dof:2 * dof], w[2 * dof:])
                if limit:
                    needed[m], names[m] = True, limit
            if progress is not None and m % every == 0:
                progress(i, m)
        if progress is not None:
            progress(i, n)
        if k.min() >= 1.0:
            break
        g *= envelope(np.where(k < 1.0, MARGIN * k, 1.0), slope / rate, int(round(lead * rate)))
        current = scaled(inputs, g)
    return g, _nearest(names, needed, g < 1.0)


def _nearest(names: np.ndarray, needed: np.ndarray, lowered: np.ndarray) -> np.ndarray:
    """Each lowered sample's name: that of the nearest ``needed`` sample."""
    out = np.full(len(names), '', dtype=object)
    where = np.flatnonzero(needed)
    if where.size == 0:
        return out
    at = np.flatnonzero(lowered)
    right = np.clip(np.searchsorted(where, at), 0, where.size - 1)
    left = np.clip(right - 1, 0, where.size - 1)
    pick = np.where(np.abs(where[left] - at) <= np.abs(where[right] - at), where[left],
                    where[right])
    out[at] = names[pick]
    return out
