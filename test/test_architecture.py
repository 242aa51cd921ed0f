"""The structure the README's layout section promises, checked on the source:
which subpackage may import which, rclpy only in the ROS adapter, no import
cycles, no function-level imports of the package's own modules, no sys.path
edits anywhere in the repository."""
from __future__ import annotations

import ast
import functools
import importlib
import os
import re
from pathlib import Path

import pytest

from flight_sim_dynamics import machines as registry

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / 'flight_sim_dynamics'
MODULES = sorted(p for p in PACKAGE.rglob('*.py'))

#: subpackage -> the package's subpackages it may import (besides itself)
ALLOWED = {
    'core': set(),
    'machines': {'core'},
    'config': {'core', 'machines'},
    'cueing': {'core', 'config', 'machines'},
    'ros': {'core', 'config', 'machines', 'cueing'},
    'cli': {'core', 'config', 'ros', 'machines', 'cueing'},
}
#: modules of ros/ that talk to rclpy (the rest of ros/ is plain Python)
RCLPY_MODULES = {'ros/dynamics_node.py', 'ros/managed_node.py', 'ros/marker_publisher.py',
                 'ros/motion_cueing.py',
                 'ros/node.py', 'ros/parameter_guard.py',
                 'ros/planner.py', 'ros/platform_sim.py', 'ros/service_thread.py',
                 'ros/sim_node.py', 'cli/demo.py'}
#: subpackages that see the machines only through the registry
#: (``flight_sim_dynamics.machines``) and the public calls
#: (``flight_sim_dynamics.machines.api``), never a machine's own modules
#: (``machines.<name>``), so that a new machine touches none of them: the
#: configuration too reads the default machine's parameters from its Machine
#: (issue 30), and core/ imports no machines/ at all
MACHINE_BLIND = ('config', 'core', 'cli', 'ros', 'cueing')
#: the gateways of MACHINE_BLIND subpackages into machines/
MACHINE_GATEWAYS = {'flight_sim_dynamics.machines', 'flight_sim_dynamics.machines.api'}
#: modules that import matplotlib (an optional extra): imported lazily, by the
#: commands that plot, so that nothing else ever needs matplotlib
LAZY = {'flight_sim_dynamics.cli.plotting', 'flight_sim_dynamics.cli.workspace',
        'flight_sim_dynamics.cli.bench', 'flight_sim_dynamics.cli.animate'}


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


@functools.lru_cache(maxsize=None)
def parsed(path: Path) -> ast.Module:
    """The syntax tree of ``path``, parsed once for all the checks of a run."""
    return ast.parse(path.read_text())


@functools.lru_cache(maxsize=None)
def imports(path: Path, source: str | None = None) -> tuple[tuple[str, bool], ...]:
    """(absolute module imported, at module level?) for every import in ``path``
    (or in ``source``, read as if it were ``path``), read once per run.
    """
    tree = parsed(path) if source is None else ast.parse(source)
    here = module_name(path).split('.')
    if path.name != '__init__.py':
        here = here[:-1]
    nested = {id(inner) for outer in ast.walk(tree)
              if isinstance(outer, (ast.FunctionDef, ast.AsyncFunctionDef))
              for inner in ast.walk(outer)}
    top_level = {id(node) for node in ast.walk(tree) if id(node) not in nested}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, id(node) in top_level) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - node.level + 1]
                target = '.'.join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ''
            found.append((target, id(node) in top_level))
            found += [(f'{target}.{alias.name}', id(node) in top_level) for alias in node.names]
    return tuple(found)


def subpackage(name: str) -> str | None:
    parts = name.split('.')
    return parts[1] if len(parts) > 1 and parts[0] == 'flight_sim_dynamics' else None


@pytest.mark.parametrize('path', MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_follow_the_layers(path):
    own = subpackage(module_name(path))
    if own not in ALLOWED:
        return  # the package's __init__/__main__ re-export the public API
    rel = str(path.relative_to(PACKAGE))
    for target, _ in imports(path):
        other = subpackage(target)
        if other in ALLOWED and other != own:
            assert other in ALLOWED[own], f'{rel} imports {target}: {own}/ may not import {other}/'
        if target.split('.')[0] == 'rclpy':
            assert rel in RCLPY_MODULES, f'{rel} imports rclpy'


def machine_modules_imported(path: Path, source: str | None = None) -> list[str]:
    """The modules of machines/ that ``path`` imports other than the gateways."""
    names = {module_name(p) for p in MODULES}
    return [target for target, _ in imports(path, source)
            if target.startswith('flight_sim_dynamics.machines.') and target in names
            and target not in MACHINE_GATEWAYS]


@pytest.mark.parametrize('sub', MACHINE_BLIND)
def test_machines_are_seen_only_through_the_registry_and_api(sub):
    """A third machine adds its folder, its config file, its tests and an entry
    point (setup.py's group flight_sim_dynamics.machines, or a plugin's own):
    nothing in these subpackages names a machine's modules."""
    offenders = [f'{path.relative_to(PACKAGE)} imports {target}'
                 for path in sorted((PACKAGE / sub).rglob('*.py'))
                 for target in machine_modules_imported(path)]
    assert not offenders, offenders


@pytest.mark.parametrize('line, caught', [
    ('from ..machines.staicu import workspace', True),
    ('from ..machines.stewart.model import StewartModel', True),
    ('import flight_sim_dynamics.machines.staicu.solver', True),
    ('from ..machines import MACHINES', False),
    ('from .. import machines as registry', False),
    ('from ..machines.api import simulate', False)])
def test_the_machine_rule_tells_a_machine_module_from_the_gateways(line, caught):
    probe = PACKAGE / 'cli' / 'probe.py'
    assert bool(machine_modules_imported(probe, line + '\n')) == caught


@pytest.mark.parametrize('path', MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_function_level_imports_of_the_package(path):
    """A function-level import of the package's own modules is how cycles get
    hidden; only optional heavy dependencies (matplotlib) are imported lazily."""
    names = {module_name(p) for p in MODULES}
    late = sorted({t for t, top in imports(path)
                   if not top and t in names and t not in LAZY
                   and not (PACKAGE / Path(*t.split('.')[1:]) / '__init__.py').is_file()})
    assert not late, f'{path.relative_to(ROOT)} imports {late} inside a function'


def test_no_import_cycles():
    names = {module_name(p): p for p in MODULES}
    graph = {name: {t for t, _ in imports(path) if t in names and t != name}
             for name, path in names.items()}
    # package __init__ files re-export submodules: an edge into a package is
    # an edge into its __init__, which is not a cycle of the modules themselves
    graph = {n: {t for t in deps if not names[t].name == '__init__.py'}
             for n, deps in graph.items()}
    state: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for dep in sorted(graph[node]):
            if state.get(dep) == 1:
                cycle = stack[stack.index(dep):] + [dep]
                pytest.fail('import cycle: ' + ' -> '.join(cycle))
            if dep not in state:
                visit(dep, stack + [dep])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


def python_files(root: Path, skip: set[str]) -> list[Path]:
    """The .py files under ``root``, not descending into folders named in ``skip``
    (rglob walked all of .venv before its files were left out)."""
    found = []
    for folder, folders, files in os.walk(root):
        folders[:] = [f for f in folders if f not in skip]
        found += [Path(folder, f) for f in files if f.endswith('.py')]
    return found


#: text that any edit of the path list (insert, append, extend) has (the tree decides; a file
#: without it is not parsed)
PATH_EDIT = re.compile(r'path[\s\\)]*\.[\s\\]*(insert|append|extend)\b')


def test_no_sys_path_edits_anywhere():
    offenders = []
    for path in python_files(ROOT, skip={'.venv', 'build', 'install', 'log', '.git'}):
        if not PATH_EDIT.search(path.read_text()):
            continue
        for node in ast.walk(parsed(path)):
            if (isinstance(node, ast.Attribute) and node.attr in {'insert', 'append', 'extend'}
                    and isinstance(node.value, ast.Attribute) and node.value.attr == 'path'
                    and isinstance(node.value.value, ast.Name) and node.value.value.id == 'sys'):
                offenders.append(f'{path.relative_to(ROOT)}:{node.lineno}')
    assert not offenders, offenders


#: where the plugin machine of test/plugin_machine lives (its module and dist-info)
PLUGIN_SITE = ROOT / 'test' / 'plugin_machine' / 'site'
#: a packaged file named after the package (and its node) names no machine
PACKAGE_NAME = 'flight_sim_dynamics'
#: a title's count of degrees of freedom ('3-DOF'), in any of its spellings
DOF = re.compile(r'(\d+)[-_ ]?dof', re.IGNORECASE)


def machine_tokens(machine) -> tuple[str, ...]:
    """What names ``machine`` in text, lower case: its name; its title, the
    title's words other than its count of degrees of freedom (``hexapod``,
    ``flight simulator``, also joined by underscores), and that count
    (``3-DOF``, matched in any spelling by :func:`naming_pattern`); its packaged
    files' stems (a stem that is the package's name excepted); the package of
    its modules (``staicu``: ``flight_sim_dynamics.machines.staicu``, a plugin's
    own top-level module).
    """
    tokens = {machine.name}
    title = machine.title.strip().lower()
    if title:
        tokens.add(title)
        words = ' '.join(DOF.sub(' ', title).split())
        if words:
            tokens |= {words, words.replace(' ', '_')}
        tokens |= {f'{count}-dof' for count in DOF.findall(title + ' ' + machine.name)}
    tokens |= {stem for stem in machine.parameter_files if stem != PACKAGE_NAME}
    module = machine.model_type.__module__.split('.')
    tokens.add(module[2] if module[:2] == [PACKAGE_NAME, 'machines'] else module[0])
    return tuple(sorted(t.lower() for t in tokens))


def naming_pattern(tokens) -> re.Pattern[str]:
    """Any of ``tokens``, case-insensitively; a count of degrees of freedom
    (``3-dof``) also as ``3dof``, ``3_dof``, ``3 DOF``, not within a longer number."""
    parts = []
    for token in sorted(set(tokens), key=len, reverse=True):
        count = re.fullmatch(r'(\d+)-dof', token)
        parts.append(rf'(?<!\d){count.group(1)}[-_ ]?dof' if count else re.escape(token))
    return re.compile('|'.join(parts), re.IGNORECASE)


@pytest.fixture(scope='module')
def registered_machines():
    """Every machine of the registry, the plugin machine of test/plugin_machine
    among them (its folder on the path, the registry read again; after the
    tests neither)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(PLUGIN_SITE))
        importlib.invalidate_caches()
        registry.clear_cache()
        try:
            found = registry.machines()
        finally:
            registry.clear_cache()
    assert {'tilt_2dof', registry.DEFAULT} <= {m.name for m in found}
    return found


def test_the_naming_rule_tells_a_machine_from_generic_text(registered_machines):
    pattern = naming_pattern(t for m in registered_machines for t in machine_tokens(m))
    for named in ('the 3-DOF machine', 'a 3dof pose', 'FLIGHT_SIMULATOR', 'a hexapod',
                  'config/stewart_6dof.yaml', 'machines.staicu', 'Staicu (2013)',
                  'the 6 DOF platform', 'tilt_2dof', 'the 2-DOF tilt platform',
                  'a flight simulator'):
        assert pattern.search(named), named
    for generic in ('flight_sim_dynamics', 'config/flight_sim_dynamics.yaml', '13-dof',
                    'tilt coordination', 'one per coordinate', 'the default machine'):
        assert not pattern.search(generic), generic


@pytest.mark.parametrize('path', [p for sub in MACHINE_BLIND
                                  for p in sorted((PACKAGE / sub).rglob('*.py'))],
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_shared_modules_name_no_machine(path, registered_machines):
    """A machine's name, title, packaged files or modules appear nowhere in the
    source (code, strings, docstrings, comments) of the shared subpackages: they
    read a machine's specifics from its Machine (issue 30)."""
    offenders = []
    for machine in registered_machines:
        pattern = naming_pattern(machine_tokens(machine))
        offenders += [f'{path.relative_to(PACKAGE)}:{number}: {match.group(0)!r} '
                      f'({machine.name})'
                      for number, line in enumerate(path.read_text().splitlines(), 1)
                      for match in pattern.finditer(line)]
    assert not offenders, '\n'.join(offenders)
