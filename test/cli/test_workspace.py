"""The workspace map (``flight-sim-dynamics workspace``): a low-resolution run
writes a PNG, a markdown page and a summary; the reported ranges agree with
``fsd.solve`` on both sides of every end; poses that need the slider E2 off
the rod are ``unreachable`` ('loop E2 on rod'), which an independent
computation of the geometry confirms. No timing is asserted."""
from __future__ import annotations

import contextlib
import io
import math
import re

import numpy as np
import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import main as cli
from flight_sim_dynamics.machines.staicu import workspace as ws

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'
MODEL = fsd.load_model()
ROLLS = (0.0, 20.0)
#: one summary interval: [+0.123 m (cause), -0.456 m (cause)]
INTERVAL = re.compile(r'\[([+-]\d+\.\d+) m \(([^)]*)\), ([+-]\d+\.\d+) m \(([^)]*)\)\]')


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('workspace')
    png, md = out / 'map.png', out / 'workspace.md'
    buf, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        rc = cli.main(['workspace', '-o', str(png), '--resolution', '40', '--rolls',
                       *(f'{r:g}' for r in ROLLS), '--markdown', str(md)])
    return rc, png, md, buf.getvalue(), err.getvalue()


def _at(q) -> fsd.Solution:
    return fsd.solve(MODEL, q, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])


def _within_strokes(sol: fsd.Solution) -> bool:
    lim = MODEL.limits
    return (sol.status != fsd.Status.UNREACHABLE
            and bool(np.all((sol.stroke >= lim.stroke_min) & (sol.stroke <= lim.stroke_max))))


def _summary_blocks(stdout: str) -> dict[float, list[str]]:
    """The range lines of the summary by roll angle."""
    blocks: dict[float, list[str]] = {}
    current = None
    for line in stdout.splitlines():
        m = re.match(r'  roll ([+-][\d.]+) deg:$', line)
        if m:
            current = float(m.group(1))
            blocks[current] = []
        elif current is not None and line.startswith('    '):
            blocks[current].append(line)
        else:
            current = None
    return blocks


# ----------------------------------------------------------------------------
# The command
# ----------------------------------------------------------------------------
def test_command_writes_png_markdown_and_summary(quick_run):
    rc, png, md, stdout, stderr = quick_run
    assert rc == 0, stderr
    assert png.read_bytes()[:8] == PNG_SIGNATURE
    text = md.read_text()
    assert text.startswith('# Workspace')
    assert '(map.png)' in text                      # the page shows the figure
    assert 'flight-sim-dynamics workspace -o' in text
    assert '| roll +0 deg |' in text and '| roll +20 deg (zoom) |' in text
    blocks = _summary_blocks(stdout)
    assert set(blocks) == set(ROLLS)
    for lines in blocks.values():
        joined = '\n'.join(lines)
        assert 'surge at heave 0 (reachable): [' in joined
        assert 'heave at surge 0 (within stroke limits): [' in joined
    for roll in ROLLS:
        head = re.escape(f'roll {roll:+g} deg')
        assert re.search(rf'^  {head}: area reachable \d+\.\d+ m\^2; within stroke '
                         r'limits \d+\.\d+ m\^2;', stdout, re.M), stdout
    # the paper's three motions are reported, and all their samples are ok
    for name in ('vertical', 'rectilinear', 'general'):
        assert re.search(rf'^  {name}: all \d+ ok;', stdout, re.M), stdout


def test_listed_in_help_and_bad_options_are_one_line_errors(tmp_path, capsys):
    assert cli.main(['--help']) == 0
    assert 'workspace' in capsys.readouterr().out
    png = str(tmp_path / 'm.png')
    for bad in (['-o', png, '--range', '1', '0', '-1', '1'], ['-o', png, '--resolution', '3'],
                ['-o', png, '--rolls', 'nan'], ['-o', str(tmp_path / 'map.unknown')],
                ['-o', str(tmp_path / 'no' / 'such' / 'dir.png')]):
        assert cli.main(['workspace', *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith('error: '), err
    assert not list(tmp_path.iterdir())             # nothing written


# ----------------------------------------------------------------------------
# Ranges agree with fsd.solve
# ----------------------------------------------------------------------------
def _pose(axis: int, x: float, roll_deg: float) -> list[float]:
    q = [0.0, 0.0, math.radians(roll_deg)]
    q[axis] = x
    return q


def test_printed_ranges_agree_with_solve(quick_run):
    """Printed to 3 decimals: 2 mm inside an end is inside, 2 mm beyond is out."""
    _, _, _, stdout, _ = quick_run
    blocks = _summary_blocks(stdout)
    step = 2e-3
    for roll, lines in blocks.items():
        checked = 0
        for line in lines:
            m = re.match(r'    (surge|heave) at \w+ 0 \((reachable|within stroke limits)\)', line)
            axis = 0 if m.group(1) == 'surge' else 1
            inside = ((lambda s: s.status != fsd.Status.UNREACHABLE) if m.group(2) == 'reachable'
                      else _within_strokes)
            lo, lo_cause, hi, hi_cause = INTERVAL.search(line.split(': ', 1)[1]).groups()
            lo, hi = float(lo), float(hi)
            assert lo < 0.0 < hi, line       # the first one holds the central configuration
            for end, cause, sign in ((lo, lo_cause, -1.0), (hi, hi_cause, 1.0)):
                assert inside(_at(_pose(axis, end - sign * step, roll))), (roll, line)
                if cause != ws.EDGE:
                    assert not inside(_at(_pose(axis, end + sign * step, roll))), (roll, line)
            checked += 1
        assert checked == 4


@pytest.mark.parametrize('roll', [0.0, 30.0])
def test_interval_ends_are_exact_and_name_the_constraint(roll):
    surge_line, heave_line = ws.line_ranges(MODEL, roll, ws.DEFAULT_RANGE, samples=801)
    eps = 1e-7
    for axis, line in ((0, surge_line), (1, heave_line)):
        for kind, inside in ((ws.KINDS[0], lambda s: s.status != fsd.Status.UNREACHABLE),
                             (ws.KINDS[1], _within_strokes)):
            ivs = line.intervals[kind]
            assert ivs and line.through_centre(kind) is not None
            for iv in ivs:
                assert iv.lo < iv.hi
                assert inside(_at(_pose(axis, iv.lo + eps, roll)))
                assert inside(_at(_pose(axis, iv.hi - eps, roll)))
                for end, cause, sign in ((iv.lo, iv.lo_cause, -1.0), (iv.hi, iv.hi_cause, 1.0)):
                    if cause == ws.EDGE:
                        continue
                    out = _at(_pose(axis, end + sign * eps, roll))
                    assert not inside(out)
                    if cause.startswith('loop') or cause == 'E2 off rod':
                        loop = {'E2 off rod': 'E2 on rod'}.get(cause, cause.removeprefix('loop '))
                        assert out.status == fsd.Status.UNREACHABLE
                        assert out.detail.startswith(f'loop {loop}:'), (cause, out.detail)
                    else:
                        leg, bound = re.match(r'stroke ([ABC]) (min|max)', cause).groups()
                        j = 'ABC'.index(leg)
                        lim = MODEL.limits
                        assert (out.stroke[j] < lim.stroke_min if bound == 'min'
                                else out.stroke[j] > lim.stroke_max)


def test_areas_match_counting_cells_and_reachability_ignores_roll():
    extent = ws.DEFAULT_RANGE
    res = 60
    cell = (extent[1] - extent[0]) * (extent[3] - extent[2]) / res ** 2
    reach_areas = []
    for roll in (0.0, 25.0):
        rm = ws.sample_map(MODEL, roll, extent, res, exact_cond=False)
        a = ws.areas(MODEL, rm, extent)
        assert not a.clipped
        assert 0.0 < a.within < a.reachable
        counted = (rm.category == ws.REACHABLE).sum() * cell
        assert a.reachable == pytest.approx(counted, rel=0.05)
        assert a.within == pytest.approx(rm.within.sum() * cell, rel=0.1)
        reach_areas.append(a.reachable)
    assert reach_areas[0] == pytest.approx(reach_areas[1], rel=1e-9)


def test_negative_roll_mirrors_positive_roll_with_legs_b_and_c_exchanged():
    a = ws.sample_map(MODEL, 20.0, ws.DEFAULT_ZOOM, 30, exact_cond=False)
    b = ws.sample_map(MODEL, -20.0, ws.DEFAULT_ZOOM, 30, exact_cond=False)
    np.testing.assert_array_equal(a.category, b.category)
    np.testing.assert_array_equal(a.within, b.within)
    np.testing.assert_allclose(a.stroke[..., [0, 2, 1]], b.stroke, atol=1e-12)


# ----------------------------------------------------------------------------
# E2 off the rod is unreachable
# ----------------------------------------------------------------------------
def _independent_e2(q) -> tuple[float, float, float]:
    """From mechanism.md alone: (loop D discriminant, loop E discriminant,
    u = |G - E2| along the rod for the machine's root, the one nearer G)."""
    g = MODEL.geometry
    G = np.array([g.d2 + g.d3 + g.d4 + q[0], g.h_G + q[1]])
    D1, E1 = np.array([g.d2 + g.d3, 0.0]), np.array([g.d2, 0.0])
    # loop D: |G - c l(beta) - D1| = l5, c = h - d1, root near beta = 0 (scan + refine)
    c = g.h - g.d1
    betas = np.linspace(-math.pi / 2, math.pi / 2, 200001)
    resid = np.hypot(G[0] - c * np.cos(betas) - D1[0], G[1] - c * np.sin(betas) - D1[1]) - g.l5
    crossings = np.flatnonzero(np.sign(resid[:-1]) != np.sign(resid[1:]))
    if not crossings.size:
        return -1.0, math.nan, math.nan
    beta = betas[crossings[np.argmin(np.abs(betas[crossings]))]]
    lvec = np.array([math.cos(beta), math.sin(beta)])
    # loop E: E2 = G - u l on the circle |E2 - E1| = l6
    w = G - E1
    p = w @ lvec
    disc = p * p - (w @ w - g.l6 ** 2)
    if disc < 0:
        return 1.0, disc, math.nan
    return 1.0, disc, p - math.sqrt(disc)


def test_poses_needing_e2_off_the_rod_are_unreachable():
    g = MODEL.geometry
    s = np.linspace(-3.0, 1.2, 43)
    h = np.linspace(-3.7, 1.5, 53)
    S, H = np.meshgrid(s, h)
    q = np.column_stack([S.ravel(), H.ravel(), np.zeros(S.size)])
    batch = fsd.solve_batch(MODEL, q, np.zeros_like(q), np.zeros_like(q))
    found = [i for i, d in enumerate(batch.detail) if d.startswith('loop E2 on rod')]
    assert len(found) > 20
    rng = np.random.default_rng(7)
    for i in rng.choice(found, size=6, replace=False):
        pose = q[i].tolist()
        sol = _at(pose)
        assert sol.status == fsd.Status.UNREACHABLE
        assert sol.detail.startswith('loop E2 on rod'), sol.detail
        assert 'E2 would leave the rod between A3 and G' in sol.detail
        assert np.all(sol.stroke == 0.0) and np.all(sol.force == 0.0)
        disc_d, disc_e, u = _independent_e2(pose)
        assert disc_d > 0.0 and disc_e >= 0.0, pose      # both loops close ...
        assert not 0.0 <= u <= g.h, (pose, u)             # ... but E2 is off A3-G
    # and the map draws them as their own cause
    rm = ws.sample_map(MODEL, 0.0, ws.DEFAULT_RANGE, 40, exact_cond=False)
    e2 = rm.category == ws.E2_OFF_ROD
    assert e2.any() and (rm.category == ws.LOOP_D).any() and (rm.category == ws.LOOP_E).any()
    S, H = np.meshgrid(rm.surge, rm.heave)
    for x, y in list(zip(S[e2], H[e2]))[::17]:
        assert _at([x, y, 0.0]).detail.startswith('loop E2 on rod')


def test_reachable_interval_through_centre_holds_the_paper_motions():
    surge_line, heave_line = ws.line_ranges(MODEL, 0.0, ws.DEFAULT_RANGE, samples=801)
    heave = heave_line.through_centre(ws.KINDS[1])
    x, y, _ = fsd.trajectories.PAPER_EXAMPLES['vertical']
    assert heave.lo < 0.0 < 2 * y < heave.hi
    assert ws.general_pose_at_roll(30.0) == pytest.approx((0.1, 0.2))
    assert ws.general_pose_at_roll(45.0) is None


def test_bounds_are_shares_of_each_boundary_and_the_reachable_one_ignores_roll():
    survey = ws.survey(MODEL, resolution=40, rolls=(0.0, 30.0), color_by='kinematic')
    overview = [p for p in survey.planes if p.row == 0]
    zoom = [p for p in survey.planes if p.row == 1]
    assert [p.title for p in overview] == ['roll +0 deg', 'roll +30 deg']
    # roll moves legs B and C only
    assert overview[0].boundary_shares(0) == overview[1].boundary_shares(0)
    for plane, which in ((overview[0], 0), (zoom[0], 1)):
        assert sum(plane.boundary_shares(which).values()) == pytest.approx(1.0)
    assert 'loop D' in overview[0].boundary_shares(0)
    assert any(k.startswith('stroke') for k in zoom[0].boundary_shares(1))
    assert 0.0 <= zoom[1].near_singular_share(1) <= 1.0


def _legend(survey):
    from flight_sim_dynamics.cli import workspace as cli_workspace

    return cli_workspace.legend_entries(survey, cli_workspace._Styles(survey.planes))


def test_the_legend_is_short_and_regions_are_drawn_one_by_one():
    """Issue 14 #9: the map had 19 legend entries and an enclosed unreachable
    region without its hatch. Related entries are grouped; every connected
    region is its own contourf (the largest first)."""
    from flight_sim_dynamics.cli import workspace as cli_workspace

    handles, labels = _legend(ws.survey(MODEL, resolution=40, rolls=(0.0, 20.0)))
    assert len(handles) == len(labels) <= 16, labels
    for word in ('loop D', 'loop E', 'E2 off the rod', 'stroke A', 'stroke B', 'stroke C',
                 'kinematic condition (blocks of Q) =', 'det(dL/dq) = 0', 'near_singular',
                 'vertical', 'rectilinear', 'general motion', 'dimmed'):
        assert sum(word in label for label in labels) == 1, (word, labels)
    r = np.hypot(*np.meshgrid(np.linspace(-1, 1, 41), np.linspace(-1, 1, 41)))
    regions = cli_workspace.regions((r < 0.2) | (r >= 0.6))      # an island inside a ring
    assert sorted(int(m.sum()) for m in regions)[0] == int((r < 0.2).sum())
    assert len(regions) == 2


def test_the_enclosed_disk_of_the_map_is_named_in_the_legend():
    """The default map has a small region of its own inside the E2-off-rod one
    (a disk, at about surge -0.25 m, heave -1.1 m): loop D, the same cause as
    the outer band, and the legend's loop D entry says it covers both."""
    model = fsd.load_model()
    surge, heave = np.meshgrid(np.linspace(-0.8, 0.2, 21), np.linspace(-1.6, -0.6, 21))
    q = np.column_stack([surge.ravel(), heave.ravel(), np.zeros(surge.size)])
    disk = ws.categorise(ws.at_rest(model, q)).reshape(surge.shape) == ws.LOOP_D
    assert disk[10, 11]                                           # (-0.25, -1.1)
    assert not (disk[0].any() or disk[-1].any() or disk[:, 0].any() or disk[:, -1].any())
    _, labels = _legend(ws.survey(model, resolution=40, rolls=(0.0,), no_zoom=True))
    loop_d = [label for label in labels if label.startswith('unreachable: loop D')]
    assert len(loop_d) == 1 and 'disk' in loop_d[0], labels


# ----------------------------------------------------------------------------
# The numbers of the survey: those the command printed for this grid when it
# drew the roll panels itself (recorded at 157a148, `workspace --resolution 40
# --rolls 0 20`), now through the shared survey and presentation
# ----------------------------------------------------------------------------
RECORDED = {
    # roll: (reachable area, within-stroke area, within-stroke heave interval and its causes)
    0.0: (4.391, 0.625, (-0.306, 'E2 off rod', 0.678, 'stroke B max, stroke C max')),
    20.0: (4.391, 0.363, (-0.236, 'stroke B min', 0.477, 'stroke C max')),
}
RECORDED_SHARES = {      # boundary of the reachable set (overview), within the strokes (zoom)
    0.0: ({'loop D': 48, 'E2 off rod': 35, 'loop E': 17},
          {'stroke B, C max': 29, 'E2 off rod': 24, 'loop E': 22, 'stroke A min': 21,
           'stroke B, C min': 3, 'stroke A max': 1}),
    20.0: ({'loop D': 48, 'E2 off rod': 35, 'loop E': 17},
           {'stroke C max': 27, 'loop E': 26, 'stroke A min': 20, 'E2 off rod': 16,
            'stroke B min': 11}),
}
RECORDED_NEAR = {0.0: 0.3, 20.0: 0.5}     # % of the within-stroke cells of the zoom
RECORDED_MOTIONS = {     # name: (max cond(Q), stroke C interval)
    'vertical': (11.7, (0.001, 0.171)), 'rectilinear': (15.3, (0.001, 0.174)),
    'general': (15.6, (0.001, 0.470))}


def test_the_survey_gives_the_recorded_numbers():
    survey = fsd.machine_of(MODEL).workspace(MODEL, resolution=40, rolls=ROLLS)
    overview = {float(p.title.split()[1]): p for p in survey.planes if p.row == 0}
    zoom = {float(p.title.split()[1]): p for p in survey.planes if p.row == 1}
    for roll, (reach, within, (lo, lo_cause, hi, hi_cause)) in RECORDED.items():
        assert round(overview[roll].area(0), 3) == reach
        assert round(overview[roll].area(1), 3) == within
        heave = next(r for r in survey.ranges if r.group == f'roll {roll:+g} deg'
                     and r.name == 'heave at surge 0' and r.which == 1)
        (a, b), = heave.intervals
        assert (round(a.value, 3), a.cause, round(b.value, 3), b.cause) == (lo, lo_cause, hi,
                                                                           hi_cause)
        shares = [{k: round(100 * v) for k, v in plane.boundary_shares(which).items()
                   if round(100 * v)} for plane, which in ((overview[roll], 0), (zoom[roll], 1))]
        assert tuple(shares) == RECORDED_SHARES[roll]
        assert round(100 * zoom[roll].near_singular_share(1), 1) == RECORDED_NEAR[roll]
    for check in survey.checks:
        assert dict(check.statuses) == {'ok': 301}
        figures = {q.label: q.value for q in check.figures}
        cond, stroke_c = RECORDED_MOTIONS[check.name]
        assert round(figures['max cond(Q)'], 1) == cond
        assert tuple(np.round(figures['stroke C'], 3)) == stroke_c


def test_the_page_tables_carry_the_survey(quick_run):
    """The markdown page of the command shows the recorded numbers in its tables."""
    _, _, md, stdout, _ = quick_run
    text = md.read_text()
    assert '| roll +0 deg | heave at surge 0 | within stroke limits | -0.306 m | +0.678 m | ' \
           'E2 off rod | stroke B max, stroke C max |' in text
    assert 'reachable 4.391 m^2; within stroke limits 0.363 m^2' in text
    assert '| vertical | all 301 ok |' in text and '[+0.001, +0.470] m' in text
