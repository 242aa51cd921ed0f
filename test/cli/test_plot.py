"""The force/power figure is readable at first look (issue 14 #9): rows
without a solution are a shaded gap, not a flat 0 N line; B stays visible
where it equals C; the sign convention is on the axes."""
from __future__ import annotations

import numpy as np

from flight_sim_dynamics.cli import plotting


def _figure(unsolved=None):
    t = np.linspace(0.0, 1.0, 11)
    force = np.column_stack([t + 30.0, t + 20.0, t + 20.0])      # B = C
    power = np.column_stack([t, -t, -t])
    if unsolved is not None:
        force[unsolved], power[unsolved] = 0.0, 0.0                # as solve writes them
    return plotting.force_power_figure(t, force, power, title='x', unsolved=unsolved)


def test_unsolved_rows_are_a_shaded_gap_not_zero():
    unsolved = np.zeros(11, bool)
    unsolved[4:7] = True
    ax_f, ax_p = _figure(unsolved).axes
    for ax in (ax_f, ax_p):
        for line in ax.get_lines()[:3]:
            y = np.asarray(line.get_ydata(), float)
            assert np.all(np.isnan(y[4:7])) and np.all(np.isfinite(y[:4]))
        labels = [h.get_label() for h in ax.get_legend().legend_handles]
        assert 'no solution (3 rows)' in labels
    assert len(ax_f.patches) == 1


def test_no_shading_when_every_row_is_solved():
    ax_f, _ = _figure().axes
    assert not ax_f.patches


def test_b_stays_visible_under_c_and_the_signs_are_labelled():
    ax_f, ax_p = _figure().axes
    b, c = ax_f.get_lines()[1], ax_f.get_lines()[2]
    assert b.get_linewidth() > c.get_linewidth() and c.get_linestyle() == '--'
    assert 'pushes' in ax_f.get_ylabel() and 'drives' in ax_p.get_ylabel()
