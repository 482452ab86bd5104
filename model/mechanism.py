"""Mechanism files (schema ``rigval-mechanism/1``): parse, check, hold in frozen dataclasses.

A mechanism is a set of rigid bodies in the plane, joined by revolute joints and pinned to the
ground, whose remaining degrees of freedom are taken by drivers that prescribe a body's absolute
angle as a law of time. The file format, key by key, is described in ``docs/mechanism.md``.

Every error is a :class:`~rigval.model.errors.MechanismError` whose ``where`` names the file
and the key path (``joints[3].bodies[1]``) and whose hint says what to change.
"""

from __future__ import annotations

import logging
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from rigval.acquisition.errors import ConfigError
from rigval.acquisition.tables import TableReader
from rigval.model.assembly import check_constraint_count
from rigval.model.errors import MechanismError
from rigval.model.laws import MAX_FREQUENCY_HZ, cycle_rate, law_from_rates
from rigval.model.mechanism_types import Body, Driver, Joint, Mechanism, PointTable

__all__ = [
    "BUILTIN_MECHANISMS",
    "BUILTIN_PREFIX",
    "SCHEMA",
    "Body",
    "Driver",
    "Joint",
    "Mechanism",
    "PointTable",
    "builtin_mechanism",
    "load_mechanism",
    "mechanism_file",
]

logger = logging.getLogger(__name__)

#: The schema string every mechanism file must carry.
SCHEMA = "rigval-mechanism/1"

#: Mechanism files shipped with rigval (``rigval/model/mechanisms/<name>.toml``).
BUILTIN_MECHANISMS = ("pendulum", "fourbar", "single_pendulum")
#: Prefix of a built-in mechanism named instead of a path (``builtin:pendulum``).
BUILTIN_PREFIX = "builtin:"

_TOP_KEYS = {"schema", "name", "description", "gravity", "bodies", "joints", "drivers"}
_BODY_KEYS = {"name", "description", "mass", "inertia", "guess", "points"}
_JOINT_KEYS = {"revolute": {"point", "type", "bodies", "description"},
               "ground": {"point", "type", "body", "at", "description"}}
_DRIVER_KEYS = {"name", "body", "law", "theta0", "omega", "harmonics", "description"}
_HARMONIC_KEYS = {"amplitude", "omega", "phase"}

# Plausible ranges of a mechanism's numbers (docs/mechanism.md, "Ranges"): far beyond any machine
# a planar rigid-body model describes, and far enough from overflow that speeds, accelerations,
# forces and their products stay finite. A value outside is a typo or a unit mix-up.
#: Largest coordinate of a point, a ground joint or a body's guessed position, m.
MAX_LENGTH_M = 1e4
#: Largest body mass, kg (a bucket-wheel excavator is about 1.4e7 kg).
MAX_MASS_KG = 1e9
#: Largest body moment of inertia about its centre of gravity, kg m2.
MAX_INERTIA_KG_M2 = 1e13
#: Largest component of gravity, m s-2 (100 g: a rig in a centrifuge).
MAX_GRAVITY_M_S2 = 1e3
#: Largest angle (``theta0``, a guessed angle, a harmonic's amplitude or phase), rad.
MAX_ANGLE_RAD = 1e6
#: Largest drive speed (``omega`` of a driver or a harmonic), rad/s: the largest cycle frequency.
MAX_OMEGA_RAD_S = 2.0 * math.pi * MAX_FREQUENCY_HZ


def builtin_mechanism(name: str) -> Path:
    """Return the path of a mechanism file shipped with rigval.

    Parameters
    ----------
    name : str
        One of :data:`BUILTIN_MECHANISMS` (``"pendulum"``, ``"fourbar"``, ``"single_pendulum"``),
        with or without ``.toml``.

    Returns
    -------
    pathlib.Path
        The installed file.
    """
    stem = name.removesuffix(".toml")
    if stem not in BUILTIN_MECHANISMS:
        raise MechanismError(f"no built-in mechanism named {name!r}",
                             where={"name": name},
                             hint=f"use one of {', '.join(BUILTIN_MECHANISMS)}")
    return Path(str(resources.files("rigval.model") / "mechanisms" / f"{stem}.toml"))


def mechanism_file(text: str | Path, base_dir: Path | None = None) -> Path:
    """Return the file of a mechanism named by a path or ``builtin:NAME`` (scene, command line).

    Parameters
    ----------
    text : str or pathlib.Path
        ``builtin:pendulum`` for a shipped mechanism, else a file path.
    base_dir : pathlib.Path, optional
        Folder a relative path is relative to (a scene's folder); default the working directory.

    Returns
    -------
    pathlib.Path
        The file (not checked for existence; :func:`load_mechanism` does).

    Raises
    ------
    MechanismError
        For ``builtin:`` with an unknown name.
    """
    value = str(text)
    if value.startswith(BUILTIN_PREFIX):
        return builtin_mechanism(value.removeprefix(BUILTIN_PREFIX))
    return (base_dir or Path()) / value


def load_mechanism(source: str | Path | Mapping[str, Any]) -> Mechanism:
    """Read and check a mechanism file, or build a mechanism from a mapping of the same layout.

    Parameters
    ----------
    source : str, pathlib.Path or mapping
        Path of a TOML file of schema ``rigval-mechanism/1``, or the parsed content as a mapping.

    Returns
    -------
    Mechanism
        The checked mechanism.

    Raises
    ------
    MechanismError
        For an unreadable file, a wrong schema, unknown keys, bodies or points, duplicate names,
        bad values, a body not connected to the ground, or a count of constraint equations that
        does not match the coordinates (too few drivers; too many that are not redundant).
        ``where`` names the file and the key path.
    """
    if isinstance(source, Mapping):
        data, origin = dict(source), "<dict>"
    else:
        path = Path(source)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError as exc:
            raise MechanismError("mechanism file not found", where={"file": str(path)},
                                 hint="check the path") from exc
        except (OSError, UnicodeDecodeError) as exc:
            raise MechanismError(f"cannot read the mechanism file: {exc}",
                                 where={"file": str(path)}) from exc
        except tomllib.TOMLDecodeError as exc:
            raise MechanismError(f"not valid TOML: {exc}", where={"file": str(path)},
                                 hint="fix the TOML syntax at the position given") from exc
        origin = str(path)
    return check_constraint_count(_Parser(file=origin).parse(data))


#: Hints for values out of range: lengths (True) and angles (False).
_WHY = {True: f"write lengths in m (at most {MAX_LENGTH_M:g} m): docs/mechanism.md, Ranges",
        False: f"write angles in rad (at most {MAX_ANGLE_RAD:g} rad): docs/mechanism.md, Ranges"}


@dataclass(frozen=True)
class _Parser(TableReader):
    """Turns a mapping into a :class:`Mechanism`, naming the file and key path in every error."""

    error: type[ConfigError] = MechanismError
    docs: str = "docs/mechanism.md"

    def vector(self, value: Any, key: str, size: int, largest: float = MAX_LENGTH_M,
               why: str = _WHY[True]) -> tuple[float, ...]:
        """Return ``size`` numbers: x and y up to ``largest`` (``why`` if not), then an angle."""
        if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != size:
            raise self.fail(key, f"expected a list of {size} numbers, got {value!r}",
                            hint=f"write [{', '.join(['x', 'y', 'theta'][:size])}] in m and rad")
        return tuple(self.number(v, f"{key}[{i}]", largest=largest, why_largest=why) if i < 2
                     else self.angle(v, f"{key}[{i}]") for i, v in enumerate(value))

    def angle(self, value: Any, key: str) -> float:
        """Return an angle in rad, at most :data:`MAX_ANGLE_RAD` in magnitude."""
        return self.number(value, key, largest=MAX_ANGLE_RAD, why_largest=_WHY[False])

    def speed(self, value: Any, key: str) -> float:
        """Return a drive speed in rad/s, at most :data:`MAX_OMEGA_RAD_S` in magnitude."""
        return self.number(value, key, largest=MAX_OMEGA_RAD_S,
                           why_largest=f"write the speed in rad/s (2 pi f; at most "
                                       f"{MAX_FREQUENCY_HZ:g} Hz): docs/mechanism.md, Ranges")

    def array(self, data: Mapping[str, Any], key: str) -> list[Any]:
        value = data.get(key, [])
        if not isinstance(value, list):
            raise self.fail(key, f"expected an array of tables [[{key}]], got {value!r}")
        return value

    def parse(self, data: Mapping[str, Any]) -> Mechanism:
        self.check_keys(data, "", _TOP_KEYS, ("schema", "bodies", "joints"))
        if data["schema"] != SCHEMA:
            raise self.fail("schema", f"unsupported schema {data['schema']!r}, expected {SCHEMA!r}",
                            hint=f'write schema = "{SCHEMA}" and the format of docs/mechanism.md')
        default_name = Path(str(self.file)).stem if self.file != "<dict>" else "unnamed mechanism"
        name = self.text(data.get("name", default_name), "name")
        gravity = self.vector(data.get("gravity", [0.0, -9.81]), "gravity", 2,
                              largest=MAX_GRAVITY_M_S2,
                              why=f"write gravity in m s-2 (at most {MAX_GRAVITY_M_S2:g})")
        bodies = self.bodies(self.array(data, "bodies"))
        joints = self.joints(self.array(data, "joints"), bodies)
        drivers = self.drivers(self.array(data, "drivers"), bodies)
        self.check_shared_points(bodies, joints)
        self.check_grounded(bodies, joints)
        return Mechanism(name=name, bodies=bodies, joints=joints, drivers=drivers,
                         gravity=(gravity[0], gravity[1]), source=str(self.file))

    def bodies(self, tables: list[Any]) -> tuple[Body, ...]:
        if not tables:
            raise self.fail("bodies", "no bodies", hint="add at least one [[bodies]] table")
        bodies: list[Body] = []
        for index, table in enumerate(tables):
            key = f"bodies[{index}]"
            self.check_keys(table, key, _BODY_KEYS, ("name", "mass", "inertia", "guess", "points"))
            name = self.text(table["name"], f"{key}.name")
            if name in (b.name for b in bodies):
                raise self.fail(f"{key}.name", f"duplicate body name {name!r}",
                                hint="give every body a unique name")
            points = table["points"]
            if not isinstance(points, Mapping) or not points:
                raise self.fail(f"{key}.points", f"expected a table of named points, got "
                                f"{points!r}",
                                hint='write points = { P1 = [x, y], ... } in the body frame, m')
            parsed = {self.text(p, f"{key}.points"): self.vector(v, f"{key}.points.{p}", 2)
                      for p, v in points.items()}
            guess = self.vector(table["guess"], f"{key}.guess", 3)
            bodies.append(Body(
                name=name,
                mass=self.number(table["mass"], f"{key}.mass", minimum=0.0,
                                 why_minimum="masses and inertias cannot be negative",
                                 largest=MAX_MASS_KG, why_largest="write the mass in kg"),
                inertia=self.number(table["inertia"], f"{key}.inertia", minimum=0.0,
                                    why_minimum="masses and inertias cannot be negative",
                                    largest=MAX_INERTIA_KG_M2,
                                    why_largest="write the moment of inertia in kg m2"),
                points=PointTable({p: (v[0], v[1]) for p, v in parsed.items()}),
                guess=(guess[0], guess[1], guess[2]),
                description=str(table.get("description", "")),
            ))
        return tuple(bodies)

    def body_ref(self, value: Any, key: str, bodies: tuple[Body, ...]) -> Body:
        name = self.text(value, key)
        for body in bodies:
            if body.name == name:
                return body
        raise self.fail(key, f"unknown body {name!r}; bodies are "
                        f"{', '.join(b.name for b in bodies)}",
                        hint="use one of the body names of [[bodies]]")

    def point_ref(self, point: str, body: Body, key: str) -> None:
        if point not in body.points:
            raise self.fail(key, f"body {body.name!r} has no point {point!r}; its points are "
                            f"{', '.join(body.points)}",
                            hint=f"add {point} to the points of body {body.name!r} or fix the name")

    def joints(self, tables: list[Any], bodies: tuple[Body, ...]) -> tuple[Joint, ...]:
        joints: list[Joint] = []
        for index, table in enumerate(tables):
            key = f"joints[{index}]"
            if not isinstance(table, Mapping):
                raise self.fail(key, f"expected a table, got {table!r}")
            kind = table.get("type")
            if not isinstance(kind, str) or kind not in _JOINT_KEYS:
                raise self.fail(f"{key}.type", f"unknown joint type {kind!r}",
                                hint='use type = "revolute" or type = "ground"')
            required = ("point", "type", "bodies") if kind == "revolute" else (
                "point", "type", "body", "at")
            self.check_keys(table, key, _JOINT_KEYS[kind], required)
            point = self.text(table["point"], f"{key}.point")
            if point in (j.name for j in joints):
                raise self.fail(f"{key}.point", f"duplicate joint at point {point!r}",
                                hint="a point carries one joint; name the joints' points apart")
            if kind == "revolute":
                pair = table["bodies"]
                if not isinstance(pair, list) or len(pair) != 2:
                    raise self.fail(f"{key}.bodies", f"expected two body names, got {pair!r}")
                first = self.body_ref(pair[0], f"{key}.bodies[0]", bodies)
                second = self.body_ref(pair[1], f"{key}.bodies[1]", bodies)
                if first is second:
                    raise self.fail(f"{key}.bodies", f"a joint needs two different bodies, got "
                                    f"{first.name!r} twice")
                self.point_ref(point, first, f"{key}.point")
                self.point_ref(point, second, f"{key}.point")
                joints.append(Joint(point, "revolute", (first.name, second.name)))
            else:
                body = self.body_ref(table["body"], f"{key}.body", bodies)
                self.point_ref(point, body, f"{key}.point")
                at = self.vector(table["at"], f"{key}.at", 2)
                joints.append(Joint(point, "ground", (body.name,), (at[0], at[1])))
        return tuple(joints)

    def drivers(self, tables: list[Any], bodies: tuple[Body, ...]) -> tuple[Driver, ...]:
        rows: list[tuple[str, str, float, float, list[tuple[float, float, float]]]] = []
        for index, table in enumerate(tables):
            key = f"drivers[{index}]"
            self.check_keys(table, key, _DRIVER_KEYS, ("name", "body", "law", "theta0", "omega"))
            name = self.text(table["name"], f"{key}.name")
            if name in (row[0] for row in rows):
                raise self.fail(f"{key}.name", f"duplicate driver name {name!r}",
                                hint="give every driver a unique name")
            body = self.body_ref(table["body"], f"{key}.body", bodies)
            if body.name in (row[1] for row in rows):
                raise self.fail(f"{key}.body", f"body {body.name!r} already has a driver",
                                hint="a body's angle can be prescribed once; remove one driver")
            if table["law"] != "harmonic":
                raise self.fail(f"{key}.law", f"unknown drive law {table['law']!r}",
                                hint='use law = "harmonic"; pass measured drive angles to '
                                     'rigval.model.solve(..., drives=...)')
            terms = table.get("harmonics", [])
            if not isinstance(terms, list):
                raise self.fail(f"{key}.harmonics", f"expected a list of tables, got {terms!r}")
            rates = []
            for h_index, term in enumerate(terms):
                h_key = f"{key}.harmonics[{h_index}]"
                self.check_keys(term, h_key, _HARMONIC_KEYS, ("amplitude", "omega"))
                rates.append((self.angle(term["amplitude"], f"{h_key}.amplitude"),
                              self.speed(term["omega"], f"{h_key}.omega"),
                              self.angle(term.get("phase", 0.0), f"{h_key}.phase")))
            rows.append((name, body.name, self.angle(table["theta0"], f"{key}.theta0"),
                         self.speed(table["omega"], f"{key}.omega"), rates))
        # Every law is written against the first driver's cycle (1 rad/s where it stands still:
        # Mechanism.excitation then refuses it as a main drive).
        cycle_omega = (cycle_rate(rows[0][3], rows[0][4]) if rows else 0.0) or 1.0
        return tuple(Driver(name, body, law_from_rates(theta0, omega, rates, cycle_omega),
                            cycle_omega) for name, body, theta0, omega, rates in rows)

    def check_shared_points(self, bodies: tuple[Body, ...], joints: tuple[Joint, ...]) -> None:
        """Check that a point named on several bodies is the revolute joint between them."""
        revolute = {j.name: set(j.bodies) for j in joints if j.kind == "revolute"}
        for point in {p for b in bodies for p in b.points}:
            owners = [b.name for b in bodies if point in b.points]
            if len(owners) > 1 and revolute.get(point) != set(owners):
                raise self.fail("bodies", f"point {point!r} is named on bodies "
                                f"{', '.join(owners)} but is not a joint between them",
                                hint="a point name shared by two bodies must be the revolute "
                                     "joint joining them; rename the other points")

    def check_grounded(self, bodies: tuple[Body, ...], joints: tuple[Joint, ...]) -> None:
        """Every body must be connected to the ground through joints."""
        reached = {j.bodies[0] for j in joints if j.kind == "ground"}
        changed = True
        while changed:
            changed = False
            for joint in joints:
                if joint.kind == "revolute" and reached.intersection(joint.bodies) \
                        and not reached.issuperset(joint.bodies):
                    reached.update(joint.bodies)
                    changed = True
        loose = [b.name for b in bodies if b.name not in reached]
        if loose:
            raise self.fail("joints", f"bodies {', '.join(loose)} are not connected to the "
                            "ground through any chain of joints",
                            hint="add a ground pin or a revolute joint linking them to the rest")
