"""Model: planar constraint-based kinematics and inverse dynamics of any mechanism file.

Public API (see ``docs/model.md``)::

    load_mechanism(source: str | Path | Mapping) -> Mechanism
    builtin_mechanism(name: str) -> Path            # "pendulum", "fourbar", "single_pendulum"
    solve(mechanism, t, *, outputs=None, points=None, joints=None, drives=None,
          tol=1e-12, cond_warn=1e4, cond_max=2.1e5) -> xarray.Dataset     # dim "time"
    solve_cycle(mechanism, angles, *, driver=None, angle_origin=None, **solve_options)
          -> xarray.Dataset                                             # dim "angle"
    interpolate_cycle(cycle: xarray.Dataset, angles) -> xarray.Dataset
    solve_stepwise(mechanism, t, *, drives=None, tol=1e-12, max_iter=20)
          -> xarray.Dataset                                        # plain reference solver

Result variables (docs/model.md, *Result contract*): ``position``, ``velocity``, ``acceleration``
(time, body, coord = x, y, theta); ``point_position``, ``point_velocity``, ``point_acceleration``
(time, point, axis = x, y); ``joint_force`` (time, joint, axis): force ON the joint's first body
(ground pin: ON the body), N; ``driver_torque`` (time, driver): torque ON the driven body, N m,
counter-clockwise positive. On request also ``support_force`` (force ON the ground at ground pins),
``kinetic_energy``, ``potential_energy``, ``drive_power`` and ``condition_number``.
"""

from rigval.acquisition.lazy import lazy_exports

#: Public names and the module defining each, imported on first use (numpy, scipy, xarray), so
#: that ``import rigval.model.errors`` stays light.
_LAZY = {"DriveLaw": "laws", "Excitation": "laws", "Harmonic": "laws",
         "BUILTIN_MECHANISMS": "mechanism", "Body": "mechanism", "Driver": "mechanism",
         "Joint": "mechanism", "Mechanism": "mechanism", "builtin_mechanism": "mechanism",
         "load_mechanism": "mechanism", "solve_stepwise": "reference",
         "EXTRA_OUTPUTS": "results", "OUTPUTS": "results", "QUANTITIES": "results",
         "interpolate_cycle": "solver", "solve": "solver", "solve_cycle": "solver"}

__all__ = [
    "BUILTIN_MECHANISMS",
    "EXTRA_OUTPUTS",
    "OUTPUTS",
    "QUANTITIES",
    "Body",
    "DriveLaw",
    "Driver",
    "Excitation",
    "Harmonic",
    "Joint",
    "Mechanism",
    "builtin_mechanism",
    "interpolate_cycle",
    "load_mechanism",
    "solve",
    "solve_cycle",
    "solve_stepwise",
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
