"""The independent 6-UPS hexapod reference against docs/design/stewart.md.

``stewart_reference`` computes the actuator forces by two formulations that
share only the geometry: (a) pinocchio's tree (rnea) with the spherical joints
as loop closures and virtual work, (b) Lagrange's equations from the bodies'
energies with exact (complex-step) derivatives.  These tests check them
against the figures of stewart.md (home leg length, static forces with and
without payload), against each other, and against physics: the actuators'
total power equals d(T + V)/dt on any motion (friction off).  Measured at the
time of writing: (a) vs (b) <= 3e-15 relative, power balance <= 2e-15.
"""

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import stewart_reference as sr

DOC = Path(__file__).resolve().parents[2] / "docs" / "design" / "stewart.md"
RTOL = 1e-10  # (a) vs (b) and the power balance, relative (measured ~1e-15)

DEFAULT = sr.machine_from_dict(sr.default_machine())
TSAI = sr.machine_from_dict(sr.tsai_2000())
MACHINES = {"default": DEFAULT, "tsai2000": TSAI}
HEXAPODS = {name: sr.PinocchioHexapod(m) for name, m in MACHINES.items()}

# stewart.md, "Check values": at rest at home, scene full / payload (80 kg at (0, 0, 0.5))
STATIC_FULL = (398.833837, 398.833837, 398.701666, 340.352260, 340.352260, 398.701666)
STATIC_PAYLOAD = (559.415973, 559.415973, 559.283803, 500.934396, 500.934396, 559.283803)

# random motions: (pose half-range, rate scale, acceleration scale); angles in rad
MOTIONS = {"random": (0.1, 0.5, 2.0), "violent": (0.2, 3.0, 60.0)}


def random_motion(seed, kind, n=40):
    rng = np.random.default_rng(seed)
    pose, rate, acc = MOTIONS[kind]
    q = rng.uniform(-pose, pose, (n, 6))
    return q, rng.normal(0.0, rate, (n, 6)), rng.normal(0.0, acc, (n, 6))


def relative(a, b):
    """Per sample max |a - b| over the legs, relative to the sample's largest |a|."""
    return np.abs(a - b).max(axis=-1) / np.maximum(np.abs(a).max(axis=-1), 1e-300)


def power_residual(m, f, q, qd, qdd):
    """|sum f_i dL_i/dt - d(T + V)/dt| / max(sum |f_i dL_i/dt|, |dE/dt|, 1 W)."""
    p = f * sr.leg_rates(m, q, qd)
    dE = sr.energy_rate(m, q, qd, qdd)
    scale = np.maximum(np.maximum(np.abs(p).sum(axis=-1), np.abs(dE)), 1.0)
    return np.abs(p.sum(axis=-1) - dE) / scale


def test_home_leg_length():
    L = sr.leg_lengths(DEFAULT, np.zeros(6))
    np.testing.assert_allclose(L, 1.2276921743519975, rtol=0, atol=1e-15)


@pytest.mark.parametrize("payload, expected", [(0.0, STATIC_FULL), (80.0, STATIC_PAYLOAD)],
                         ids=["full", "payload"])
@pytest.mark.parametrize("formulation", [sr.forces_pinocchio, sr.forces_lagrange],
                         ids=["pinocchio", "lagrange"])
def test_static_check_values(formulation, payload, expected):
    m = sr.machine_from_dict(sr.with_payload(sr.default_machine(), payload, (0.0, 0.0, 0.5)))
    zero = np.zeros((1, 6))
    f = formulation(m, zero, zero, zero)[0]
    np.testing.assert_allclose(f, expected, rtol=0, atol=1e-6)


def test_payload_inertia_does_not_act_at_rest():
    spinning = sr.with_payload(sr.default_machine(), 80.0, (0.0, 0.0, 0.5), (5, 0, 1, 0, 7, 0, 1, 0, 9))
    zero = np.zeros((1, 6))
    f = sr.forces_pinocchio(sr.machine_from_dict(spinning), zero, zero, zero)[0]
    np.testing.assert_allclose(f, STATIC_PAYLOAD, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_tree_closes_the_loops(name):
    """The tree's configuration puts every rod end on its platform joint."""
    hexapod = HEXAPODS[name]
    q = random_motion(1, "violent", n=5)[0]
    for pose in q:
        x, _ = hexapod.configuration(pose)
        pin.framesForwardKinematics(hexapod.model, hexapod.data, x)
        tips = np.array([hexapod.data.oMf[f].translation for f in hexapod.f_tip])
        joints = np.array([hexapod.data.oMf[f].translation for f in hexapod.f_P])
        np.testing.assert_allclose(tips, joints, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_energy_of_tree_and_closed_form_agree(name):
    """Pinocchio's T and V of the closed tree equal the closed-form energies of (b)."""
    q, qd, _ = random_motion(2, "violent", n=20)
    T_a, V_a = sr.energy_pinocchio(HEXAPODS[name], q, qd)
    T_b, V_b = sr.energy(MACHINES[name], q, qd)
    np.testing.assert_allclose(T_a, T_b, rtol=1e-12)
    np.testing.assert_allclose(V_a, V_b, rtol=1e-12)


@pytest.mark.parametrize("kind", sorted(MOTIONS))
@pytest.mark.parametrize("name", sorted(MACHINES))
def test_formulations_agree(name, kind):
    q, qd, qdd = random_motion(3, kind)
    f_a = sr.forces_pinocchio(HEXAPODS[name], q, qd, qdd)
    f_b = sr.forces_lagrange(MACHINES[name], q, qd, qdd)
    assert relative(f_a, f_b).max() < RTOL


@pytest.mark.parametrize("kind", sorted(MOTIONS))
@pytest.mark.parametrize("name", sorted(MACHINES))
def test_power_balance(name, kind):
    """sum f_i dL_i/dt = d(T + V)/dt for the forces of both formulations."""
    m = MACHINES[name]
    q, qd, qdd = random_motion(4, kind)
    assert power_residual(m, sr.forces_pinocchio(HEXAPODS[name], q, qd, qdd), q, qd, qdd).max() < RTOL
    assert power_residual(m, sr.forces_lagrange(m, q, qd, qdd), q, qd, qdd).max() < RTOL


def test_leg_spin_matters():
    """The U-joint's spin about the leg (inertia_along) is in both formulations."""
    q, qd, qdd = random_motion(5, "violent", n=10)
    axial = sr.forces_pinocchio(HEXAPODS["default"], q, qd, qdd)
    no_spin = sr.default_machine()
    for body in ("cylinder", "rod"):
        no_spin[sr.SECTION]["ros__parameters"]["bodies"][body]["inertia_along"] = 0.0
    changed = sr.forces_pinocchio(sr.machine_from_dict(no_spin), q, qd, qdd)
    assert relative(axial, changed).max() > 1e3 * RTOL


def test_base_axes_do_not_act_on_legs_without_axial_inertia():
    """With inertia_along = 0 (Tsai's legs) the U-joints' first axes drop out of the forces."""
    q, qd, qdd = random_motion(6, "violent", n=10)
    tilted = sr.tsai_2000()
    geometry = tilted[sr.SECTION]["ros__parameters"]["geometry"]
    geometry["base_axes"] = [0.6, 0.0, 0.8] * 6  # not across the legs, not horizontal
    f = sr.forces_pinocchio(HEXAPODS["tsai2000"], q, qd, qdd)
    np.testing.assert_allclose(sr.forces_lagrange(sr.machine_from_dict(tilted), q, qd, qdd), f,
                               rtol=0, atol=RTOL * np.abs(f).max())


TSAI_T = np.linspace(0.0, 2.0 * np.pi / sr.TSAI_OMEGA, 121)  # one period


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_tsai_motions(k):
    q, qd, qdd = sr.tsai_motion(k, TSAI_T)
    f_a = sr.forces_pinocchio(HEXAPODS["tsai2000"], q, qd, qdd)
    f_b = sr.forces_lagrange(TSAI, q, qd, qdd)
    print(f"\nTsai motion {k}: peak |f_i| (N) " + " ".join(f"{x:.6f}" for x in np.abs(f_a).max(axis=0)))
    assert relative(f_a, f_b).max() < RTOL
    assert power_residual(TSAI, f_a, q, qd, qdd).max() < RTOL
    if k in (3, 4):  # motions in the machine's plane of symmetry y = 0: legs 1|4, 2|3, 5|6 alike
        np.testing.assert_allclose(f_a[:, [0, 1, 4]], f_a[:, [3, 2, 5]], rtol=1e-12)
    if k == 4:
        np.testing.assert_allclose(f_a, np.broadcast_to(f_a[0], f_a.shape), rtol=0, atol=1e-12)


def _doc_yaml_blocks():
    text = DOC.read_text(encoding="utf-8")
    return [yaml.safe_load(b) for b in re.findall(r"```yaml\n(.*?)```", text, flags=re.S)
            if "machine: stewart_" in b and "[...]" not in b]


def test_design_doc_files_are_the_reference_machines():
    """The two parameter files printed in docs/design/stewart.md are the reference's."""
    blocks = _doc_yaml_blocks()
    assert blocks == [sr.default_machine(), sr.tsai_2000()]


def test_machine_yaml_round_trip(tmp_path):
    for d in (sr.default_machine(), sr.tsai_2000()):
        path = tmp_path / "machine.yaml"
        path.write_text(sr.machine_yaml(d), encoding="utf-8")
        assert sr.load_machine(path) == d


def test_loader_rejects_a_short_joint_list():
    d = sr.default_machine()
    d[sr.SECTION]["ros__parameters"]["geometry"]["base_joints"].pop()
    with pytest.raises(ValueError, match="base_joints"):
        sr.machine_from_dict(d)
