"""Scenes: a named set of effects (:mod:`..core.effects`) and parameter
overrides, read from ``config/scenes/*.yaml`` or any path.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Collection, Mapping

from ..core.effects import EFFECT_NAMES, Effects
from .errors import ParameterError, did_you_mean
from ..machines import default_machine
from .files import default_params_path, flatten
from .yaml_io import read_yaml

DEFAULT_SCENE = 'full'
SCENE_KEYS = ('description', 'effects', 'parameters')


class SceneError(ParameterError):
    """A scene file is missing or malformed: a ParameterError of ``scene``."""

    def __init__(self, scene: str, reason: str) -> None:
        super().__init__('scene', scene, reason)
        self.scene = scene
        self.args = (f"scene '{scene}': {reason}",)


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    effects: Effects
    parameters: Mapping[str, Any]   # flat dotted overrides of model parameters
    path: Path | None = None        # the file, when not a packaged scene


def scenes_dir() -> Path:
    """The packaged scenes folder (next to the packaged parameter file)."""
    return default_params_path().parent / 'scenes'


def available_scenes() -> list[str]:
    folder = scenes_dir()
    return sorted(p.stem for p in folder.glob('*.yaml')) if folder.is_dir() else []


def load_scene(scene: str | os.PathLike[str] | None = None,
               names: Collection[str] | None = None) -> Scene:
    """Read and validate a scene: a name of the packaged scenes folder or the
    path of a YAML file (None: the ``full`` scene).
    ``names``: the parameters its overrides may name, those of the machine it
    is for (None: the default machine's); their values are checked when the
    model is built (:func:`.machine_files.model_of_values`, a SceneError
    naming the scene's file and the key).
    """
    text = os.fspath(DEFAULT_SCENE if scene is None else scene)
    path = Path(text) if text.endswith(('.yaml', '.yml')) or os.sep in text else (
        scenes_dir() / f'{text}.yaml')
    try:
        found = path == Path(text) or path.is_file()    # a path given: read_yaml says why not
    except OSError:             # e.g. a name too long for the file system
        found = False
    if not found:
        available = available_scenes()
        raise SceneError(text, 'no such scene; available: ' + ', '.join(available)
                         + did_you_mean(text, available))
    name = path.stem
    try:
        doc = read_yaml(path, 'scene')
    except ParameterError as exc:       # the file (key 'scene') or a key in it
        where = f'{path}: ' if exc.key == 'scene' else f"{path}: key '{exc.key}': "
        raise SceneError(name, where + exc.reason) from None
    if not isinstance(doc, Mapping):
        raise SceneError(name, "expected a map with 'effects' (and optionally "
                               "'description', 'parameters')")
    unknown_keys = sorted(map(str, set(doc) - set(SCENE_KEYS)))
    if unknown_keys:
        raise SceneError(name, f"unknown key(s): {', '.join(unknown_keys)}"
                         + did_you_mean(unknown_keys[0], SCENE_KEYS))
    effects = doc.get('effects')
    if not isinstance(effects, Mapping):
        raise SceneError(name, "missing 'effects' map")
    unknown = sorted(map(str, set(effects) - set(EFFECT_NAMES)))
    if unknown:
        raise SceneError(name, f"unknown effect(s): {', '.join(unknown)}; "
                               f"known: {', '.join(EFFECT_NAMES)}"
                         + did_you_mean(unknown[0], EFFECT_NAMES))
    missing = [e for e in EFFECT_NAMES if e not in effects]
    if missing:
        raise SceneError(name, f"effect(s) not given: {', '.join(missing)} "
                               '(every effect must be listed true or false)')
    for effect, value in effects.items():
        if not isinstance(value, bool):
            raise SceneError(name, f"effect '{effect}' must be true or false, got {value!r}")
    overrides = doc.get('parameters') or {}
    if not isinstance(overrides, Mapping):
        raise SceneError(name, "'parameters' must be a map of parameter overrides")
    description = doc.get('description', '')
    if not isinstance(description, str):
        raise SceneError(name, "'description' must be a string")
    parameters = flatten(overrides)
    known = (default_machine().parameters - {'machine', 'scene'}) if names is None else names
    for key in parameters:
        if key not in known:
            raise SceneError(name, f"parameter '{key}' is not a model parameter"
                             + did_you_mean(key, known))
    packaged = path.resolve().parent == scenes_dir().resolve()
    return Scene(name=name, description=description, effects=Effects(**effects),
                 parameters=parameters, path=None if packaged else path)
