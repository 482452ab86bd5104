"""Joint force projected on a body's axis (rod axial force, tension positive): closed forms."""

from __future__ import annotations

import numpy as np
import pytest

import rigval.model as model
from rigval.acquisition.errors import ChannelNotFoundError
from rigval.model.results import axial_joint_force

G = 9.81  # m s-2, the mechanisms' gravity


def _whirling_pendulum(omega: float) -> model.Mechanism:
    """A body turning at constant speed about a ground pin 0.5 m from its centre of gravity."""
    return model.load_mechanism({
        "schema": "rigval-mechanism/1", "name": "whirling rod", "gravity": [0.0, -G],
        "bodies": [{"name": "R", "mass": 5.0, "inertia": 0.2, "guess": [0.0, -0.5, 0.0],
                    "points": {"O": [0.0, 0.5], "tip": [0.0, -0.3]}}],
        "joints": [{"point": "O", "type": "ground", "body": "R", "at": [0.0, 0.0]}],
        "drivers": [{"name": "theta_R", "body": "R", "law": "harmonic", "theta0": 0.0,
                     "omega": omega, "harmonics": []}]})


@pytest.mark.parametrize("omega", [0.0, 3.0, 12.0])
def test_whirling_rod_axial_force_is_centripetal_plus_gravity(omega: float) -> None:
    mech = _whirling_pendulum(omega)
    t = np.linspace(0.0, 2.0, 41)
    result = model.solve(mech, t, outputs=["joint_force", "position"])
    axial = axial_joint_force(result, mech, "O", "R").to_numpy()
    theta = omega * t
    # unit vector pivot -> tip in the global frame: local (0, -1) rotated by theta
    u = np.stack([np.sin(theta), -np.cos(theta)])
    # tension = m omega^2 r + m g . u  (hanging at rest: m g)
    expected = 5.0 * omega**2 * 0.5 + 5.0 * (np.array([0.0, -G]) @ u)
    np.testing.assert_allclose(axial, expected, rtol=1e-9, atol=1e-9)
    if omega == 0.0:
        np.testing.assert_allclose(axial, 5.0 * G, rtol=1e-12)  # hanging: tension m g


def test_pendulum_rod_projection_matches_global_vectors() -> None:
    mech = model.load_mechanism(model.builtin_mechanism("pendulum"))
    t = np.linspace(0.0, 1.0, 25)
    result = model.solve(mech, t, outputs=["joint_force", "position", "point_position"],
                         joints=["P5", "P2"], points=["P5", "P2"])
    p5 = result["point_position"].sel(point="P5").to_numpy()
    p2 = result["point_position"].sel(point="P2").to_numpy()
    u = (p2 - p5) / np.linalg.norm(p2 - p5, axis=1, keepdims=True)
    # P5 joins B (first body) and F: joint_force P5 is the force on B
    f5 = result["joint_force"].sel(joint="P5").to_numpy()
    np.testing.assert_allclose(axial_joint_force(result, mech, "P5", "B").to_numpy(),
                               -np.sum(f5 * u, axis=1), rtol=1e-9, atol=1e-6)
    # P2 joins A (first body) and B: the force on B is minus joint_force P2
    f2 = -result["joint_force"].sel(joint="P2").to_numpy()
    np.testing.assert_allclose(axial_joint_force(result, mech, "P2", "B").to_numpy(),
                               -np.sum(f2 * -u, axis=1), rtol=1e-9, atol=1e-6)
    # the crank end seen from the crank F (towards its pivot P3): the same pin force, other body
    on_f = axial_joint_force(result, mech, "P5", "F", "P3").to_numpy()
    assert np.all(np.isfinite(on_f))


def test_axial_force_bad_names() -> None:
    mech = model.load_mechanism(model.builtin_mechanism("pendulum"))
    result = model.solve(mech, np.array([0.0]), outputs=["joint_force", "position"])
    with pytest.raises(ChannelNotFoundError, match="does not connect"):
        axial_joint_force(result, mech, "P5", "A")
    with pytest.raises(ChannelNotFoundError, match="3 points besides"):
        axial_joint_force(result, mech, "P2", "A")
    with pytest.raises(ChannelNotFoundError, match="not a point of body"):
        axial_joint_force(result, mech, "P5", "B", "P1")
