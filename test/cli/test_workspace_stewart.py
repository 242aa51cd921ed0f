"""``flight-sim-dynamics workspace --params <hexapod>``: the machine's maps
(Machine.workspace) as a PNG, the ranges through home and a line per map on
stdout and in the markdown page; the other machine's options are refused."""
from __future__ import annotations

import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.machines.stewart import workspace as ws

PARAMS = 'config/stewart_6dof.yaml'


def test_writes_png_markdown_and_the_ranges(tmp_path, capsys):
    png, md = tmp_path / 'ws.png', tmp_path / 'ws.md'
    assert main(['workspace', '--params', PARAMS, '-o', str(png), '--markdown', str(md),
                 '--resolution', '30', '--at', '0.05', '5', '0', '10', '--yaws', '0']) == 0
    out = capsys.readouterr().out
    assert png.read_bytes().startswith(b'\x89PNG')
    page = md.read_text()
    assert '](ws.png)' in page
    model = fsd.load_model(PARAMS)
    for k, name in enumerate(ws.COORDINATES):
        lo, hi = ws.line_range(model, k)
        unit = 'deg' if k in ws.ANGLES else 'm'
        fmt = '{:+.3f}' if unit == 'm' else '{:+.1f}'
        row = (f'| {name} | {fmt.format(lo.value)} {unit} | {fmt.format(hi.value)} {unit} | '
               f'{lo.cause} | {hi.cause} |')
        assert row in page
        assert f'  {name}: [{fmt.format(lo.value)} {unit} ({lo.cause}), ' in out
    assert 'surge-heave at sway 0.05 m, roll 5, pitch 0, yaw 10 deg' in page
    assert page.count('| roll-pitch at home, yaw 0 deg |') == 1


@pytest.mark.parametrize('params, option', [
    (PARAMS, ['--rolls', '10']), (PARAMS, ['--no-zoom']), (None, ['--at', '0', '0', '0', '0']),
    (None, ['--yaws', '10'])])
def test_options_of_the_other_machine_are_refused(tmp_path, capsys, params, option):
    argv = ['workspace', '-o', str(tmp_path / 'ws.png'), '--resolution', '20'] + option
    argv += ['--params', params] if params else []
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: --') and 'not an option' in err[0]
    assert not (tmp_path / 'ws.png').exists()


@pytest.mark.parametrize('option', [['--yaws', 'nan'], ['--orientation-range', '1', '0', '0', '1'],
                                    ['--range', '0', '1', '1', '1']])
def test_bad_map_options_are_one_line_errors(tmp_path, capsys, option):
    assert main(['workspace', '--params', PARAMS, '-o', str(tmp_path / 'ws.png')] + option) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: --')


def test_every_map_names_its_axes_and_the_colour_bar_reads_plainly(tmp_path, monkeypatch):
    """The roll-pitch maps beside surge-heave say pitch on their vertical axis;
    the colour bar of a condition range under a decade has several ticks, as
    plain numbers (no 3x10^0)."""
    pytest.importorskip('matplotlib')
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    saved = []
    original = Figure.savefig
    monkeypatch.setattr(Figure, 'savefig',
                        lambda self, *a, **k: (saved.append(self), original(self, *a, **k)))
    assert main(['workspace', '--params', PARAMS, '-o', str(tmp_path / 'ws.png'),
                 '--resolution', '30', '--yaws', '0', '20']) == 0
    fig, = saved
    FigureCanvasAgg(fig).draw()
    maps = [ax for ax in fig.axes if ax.get_title()]
    assert len(maps) == 3
    assert [ax.get_ylabel().split(' ')[0] for ax in maps] == ['heave', 'pitch', '']
    bar, = (ax for ax in fig.axes if ax.get_ylabel().startswith('condition'))
    labels = [t.get_text() for t in bar.get_yticklabels() if t.get_text()]
    assert len(labels) >= 3, labels
    assert all(float(text) > 0 for text in labels), labels
