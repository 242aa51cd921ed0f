"""Shared data of the hexapod's tests, read from docs/design/stewart.md (the
machines' parameter files, the check values) so that no number is copied."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import yaml

from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.core.effects import Effects
from flight_sim_dynamics.machines.stewart import model as stewart_model

DOC = (Path(__file__).resolve().parents[3] / 'docs' / 'design' / 'stewart.md').read_text(
    encoding='utf-8')


def doc_machines() -> dict:
    """The parameters (``ros__parameters``) of the packaged files printed in
    stewart.md, by machine name."""
    blocks = [yaml.safe_load(b)[PACKAGED_SECTION]['ros__parameters']
              for b in re.findall(r'```yaml\n(.*?)```', DOC, flags=re.S)
              if 'machine: stewart_' in b and '[...]' not in b]
    return {b['machine']: b for b in blocks}


def _numbers(text: str) -> tuple[float, ...]:
    return tuple(float(x) for x in text.split(','))


def doc_static_forces() -> dict:
    """The check values at rest at home: {'full': f, 'payload': f}, and the payload."""
    full, payload = re.findall(r'`(?:f = )?\(([-\d., ]+)\) N`', DOC)
    mass, com = re.search(r'With an ([\d.]+) kg payload at \(([-\d., ]+)\)', DOC).groups()
    return {'full': _numbers(full), 'payload': _numbers(payload),
            'payload_mass': float(mass), 'payload_com': _numbers(com)}


def doc_tsai_peaks() -> dict:
    """Tsai's motions' peak |f_i| (N) over one period: {k: (6 numbers)}."""
    rows = re.findall(r'^\| \((\d)\) [^|]*((?:\| [\d.]+ )+)\|$', DOC, flags=re.M)
    return {int(k): _numbers(cells.replace('|', ',').strip(' ,')) for k, cells in rows}


def doc_number(pattern: str) -> float:
    """The number that the regular expression's group finds in stewart.md."""
    return float(re.search(pattern, DOC).group(1))


MACHINES = doc_machines()
FULL = Effects()                                  # gravity, platform and leg inertia
WITH_PAYLOAD = Effects(payload=True)


def model_of(name: str, effects: Effects = FULL) -> stewart_model.StewartModel:
    return stewart_model.from_dict(MACHINES[name], effects)


#: Random motions: (pose half-range m or rad, rate scale, acceleration scale).
MOTIONS = {'gentle': (0.1, 0.5, 2.0), 'violent': (0.2, 3.0, 60.0)}


def random_motion(seed: int, kind: str, n: int = 20):
    """n samples (q, qd, qdd) about the model's home."""
    rng = np.random.default_rng(seed)
    pose, rate, acc = MOTIONS[kind]
    return (rng.uniform(-pose, pose, (n, 6)), rng.normal(0.0, rate, (n, 6)),
            rng.normal(0.0, acc, (n, 6)))
