"""The scene checked against its mechanism: every model name it uses exists there.

:func:`check_mechanism_names` is the check :func:`rigval.validation.scene.load_scene` runs after
parsing (the comparisons' items, body and toward points, the measured drivers, the predicted
points and supports); an unknown name is a :class:`~rigval.validation.errors.SceneError` at its
key path.
"""

from __future__ import annotations

from rigval.acquisition.tables import TableReader
from rigval.model.mechanism_names import MechanismNames
from rigval.model.output_values import ModelOutput
from rigval.validation.errors import SceneError
from rigval.validation.scene_types import MODEL_QUANTITIES, Scene

__all__ = ["check_mechanism_names"]

_error = TableReader(SceneError, docs="docs/scene.md").fail


def check_mechanism_names(scene: Scene, names: MechanismNames) -> None:
    """Check the scene's model references against a mechanism's names.

    Parameters
    ----------
    scene : Scene
        The parsed scene.
    names : MechanismNames
        What the mechanism defines.

    Raises
    ------
    SceneError
        Naming the key of the first unknown item, driver or ground joint.
    """
    for comparison in scene.comparisons:
        kind = MODEL_QUANTITIES[comparison.model.quantity][0]
        known = names.of_kind(kind)
        if comparison.model.item not in known:
            raise _error(f"{comparison.key}.model.item",
                         f"unknown {kind} {comparison.model.item!r} for "
                         f"{comparison.model.quantity} in {scene.mechanism.name}",
                         hint=f"{kind}s are {', '.join(known)}")
        if comparison.model.body is not None and names.joint_bodies:
            _check_axial(comparison.model, comparison.key, names)
    if scene.model.drives == "measured":
        for name in scene.model.drivers:
            if name not in names.drivers:
                raise _error(f"model.drivers.{name}", f"unknown driver {name!r}",
                             hint=f"drivers are {', '.join(names.drivers)}")
        missing = [d for d in names.drivers if d not in scene.model.drivers]
        if missing:
            raise _error(f"model.drivers.{missing[0]}", "missing: with drives = \"measured\" "
                         "every driver needs an encoder", hint="add the table or set drives = "
                         '"analytic"')
    for i, point in enumerate(scene.predictions.points):
        if point not in names.points:
            raise _error(f"predictions.points[{i}]", f"unknown point {point!r}",
                         hint=f"points are {', '.join(names.points)}")
    for i, joint in enumerate(scene.predictions.supports or ()):
        if joint not in names.ground_joints:
            raise _error(f"predictions.supports[{i}]", f"{joint!r} is not a ground joint",
                         hint=f"ground joints are {', '.join(names.ground_joints)}")


def _check_axial(output: ModelOutput, key: str, names: MechanismNames) -> None:
    """Check the body and toward point of a ``joint_axial_force`` against the mechanism."""
    bodies = names.joint_bodies[output.item]
    if output.body not in bodies:
        raise _error(f"{key}.model.body", f"joint {output.item!r} does not connect body "
                     f"{output.body!r}", hint=f"it connects {', '.join(bodies)}")
    others = [p for p in names.body_points[output.body or ""] if p != output.item]
    if output.toward is None and len(others) != 1:
        raise _error(f"{key}.model.toward", f"body {output.body!r} has {len(others)} points "
                     f"besides {output.item!r}: name the one that gives its axis",
                     hint=f"points: {', '.join(others)}")
    if output.toward is not None and output.toward not in others:
        raise _error(f"{key}.model.toward", f"{output.toward!r} is not a point of body "
                     f"{output.body!r} other than {output.item!r}",
                     hint=f"points: {', '.join(others)}")
