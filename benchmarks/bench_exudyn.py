"""rigval.model.solve against Exudyn 1.13.6: full inverse dynamics of pendulum.toml, one run.

Run (Exudyn is not a rigval dependency; install it next to rigval in a throwaway venv):

    python3 -m venv /tmp/exu && /tmp/exu/bin/pip install exudyn==1.13.6 /path/to/rigval
    /tmp/exu/bin/python benchmarks/bench_exudyn.py [--steps 100000] [--repeats 3] \
        [--threads default|1]

Both solvers compute the same thing for the same 100,000 steps (20 s at 5 kHz): positions,
velocities, accelerations, all 11 joint forces and both drive torques of the builtin pendulum,
and return the forces and torques of every step.

- rigval: ``rigval.model.solve(mech, t, outputs=["joint_force", "driver_torque"])`` (``--outputs
  all``: every output, also body and point kinematics), in this process as a user would call it
  (``--threads default``: no BLAS settings; ``--threads 1``: OPENBLAS_NUM_THREADS=1 set before
  numpy is imported).
- Exudyn: 8 ``ObjectRigidBody2D``, 7 ``RevoluteJoint2D`` and 4 ground pins (``RevoluteJoint2D``
  to ``ObjectGround``), the two drive laws as ``CoordinateConstraint`` on the driven bodies'
  angle with a *symbolic* (C++-evaluated) offset user function, gravity as
  ``LoadMassProportional``; ``SolveDynamic`` (generalised-alpha, index 3, Newton) with 100,000
  steps, started from rigval's consistent positions and velocities at t = 0; the 11 joint
  forces and 2 drive torques are recorded at every step by sensors kept in memory. The
  constraint reactions (Lagrange multipliers) of an index-3 DAE with prescribed motion are the
  inverse dynamics.

Exudyn runs with its fastest settings for this small system (dense LU, modified Newton, the
``exudynCPPfast`` build) and index-3 generalised-alpha with spectral radius 0.6.

Errors are the largest deviation over all joint forces and torques relative to their peak, on
every 50th step, against the plain step-by-step solve ``rigval.model.solve_stepwise`` (its own
independent full-coordinate Newton and LAPACK solves). Wall times: the two solvers alternate
``--repeats`` times; the ratio is Exudyn's best wall time over rigval's best, measured in this
one run, and each repeat's ratio is printed too, as is the ratio of the best CPU times
(rigval runs on one BLAS thread, Exudyn on one thread: CPU time is less disturbed by other
work). The 1-minute load average is printed before and after.
"""

from __future__ import annotations

import argparse
import os
import sys

if "--threads" in sys.argv and sys.argv[sys.argv.index("--threads") + 1] == "1":
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[_var] = "1"

import time

import numpy as np

import rigval.model as rm

FS = 5000.0
#: What the Exudyn run records at every step (rigval computes positions, velocities and
#: accelerations on the way, as Exudyn does).
FORCES = ["joint_force", "driver_torque"]
STRIDE = 50


def best_wall(func, repeats):
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return result, best


def timed(func):
    """Return ``func()``, its wall time and the CPU time of this process, s."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = func()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def rel_error(value, reference):
    value, reference = np.asarray(value), np.asarray(reference)
    return float(np.max(np.abs(value - reference)) / np.max(np.abs(reference)))


def forces_of(ds):
    """(n, 2 * n_joints + n_drivers): joint force x, y per joint, then the drive torques."""
    joint = ds["joint_force"].transpose("time", "joint", "axis").to_numpy()
    return np.concatenate([joint.reshape(joint.shape[0], -1),
                           ds["driver_torque"].to_numpy()], axis=1)


def _offset_law(driver, reference, esym):
    """The drive law as an Exudyn offset user function (recorded symbolically).

    Exudyn's node coordinates are displacements from the reference coordinates, so the offset
    is the law minus the node's reference angle ``reference`` (rad).
    """
    def offset(mbs, t, itemNumber, lOffset):
        value = (driver.theta0 - reference) + driver.omega * t
        for h in driver.law.harmonics:
            value = value + h.amplitude * esym.sin(h.order * driver.cycle_omega * t + h.phase)
        return value
    return offset


def build_exudyn(mech, start, n_steps, end_time):
    """Exudyn model of ``mech`` started from rigval's state ``start`` (solve at t = 0)."""
    import exudyn as exu
    import exudyn.advancedUtilities as eau
    from exudyn.itemInterface import (
        CoordinateConstraint,
        LoadMassProportional,
        MarkerBodyMass,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectGround,
        ObjectRigidBody2D,
        RevoluteJoint2D,
        SensorObject,
    )

    esym = exu.symbolic
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    ground_node = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    ground_coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    pos = start["position"].isel(time=0).to_numpy()  # body, coord (x, y, theta)
    vel = start["velocity"].isel(time=0).to_numpy()
    bodies, nodes = {}, {}
    gravity = [*mech.gravity, 0.0]
    for i, body in enumerate(mech.bodies):
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(pos[i]),
                                           initialVelocities=list(vel[i])))
        obj = mbs.AddObject(ObjectRigidBody2D(mass=body.mass, inertia=body.inertia,
                                              nodeNumber=node))
        mass_marker = mbs.AddMarker(MarkerBodyMass(bodyNumber=obj))
        mbs.AddLoad(LoadMassProportional(markerNumber=mass_marker, loadVector=gravity))
        bodies[body.name], nodes[body.name] = obj, node
    point = {b.name: b.points for b in mech.bodies}
    sensors = []
    for joint in mech.joints:
        first = joint.bodies[0]
        m_first = mbs.AddMarker(MarkerBodyPosition(
            bodyNumber=bodies[first], localPosition=[*point[first][joint.name], 0.0]))
        if joint.kind == "ground":
            m_other = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground,
                                                       localPosition=[*joint.at, 0.0]))
        else:
            second = joint.bodies[1]
            m_other = mbs.AddMarker(MarkerBodyPosition(
                bodyNumber=bodies[second], localPosition=[*point[second][joint.name], 0.0]))
        # Exudyn's Force output of a joint (and of a coordinate constraint) is the reaction with
        # the opposite sign to rigval's joint_force (force ON the first body) and driver_torque.
        obj = mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_other, m_first]))
        sensors.append(mbs.AddSensor(SensorObject(objectNumber=obj, storeInternal=True,
                                                  outputVariableType=exu.OutputVariableType.Force,
                                                  writeToFile=False)))
    keep = []  # symbolic user functions must outlive the simulation
    for driver in mech.drivers:
        offset = _offset_law(driver, pos[mech.body_names.index(driver.body)][2], esym)
        coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[driver.body], coordinate=2))
        obj = mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_coord, coord]))
        func = eau.CreateSymbolicUserFunction(mbs, offset, "offsetUserFunction", obj)
        mbs.SetObjectParameter(obj, "offsetUserFunction", func)
        keep.append(func)
        sensors.append(mbs.AddSensor(SensorObject(objectNumber=obj, storeInternal=True,
                                                  outputVariableType=exu.OutputVariableType.Force,
                                                  writeToFile=False)))
    mbs.Assemble()
    settings = exu.SimulationSettings()
    settings.timeIntegration.numberOfSteps = n_steps
    settings.timeIntegration.endTime = end_time
    settings.timeIntegration.verboseMode = 0
    # Index 3 with numerical damping: rho = 1 leaves the reactions oscillating (errors of 2x the
    # peak force), Exudyn's usual 0.9 leaves 7e-4 at the start, 0.6 gives 1e-6 throughout.
    settings.timeIntegration.generalizedAlpha.spectralRadius = 0.6
    # Exudyn's fastest settings for a small system: dense LU, Jacobian reused between steps
    # (each measured faster here than the sparse solver and full Newton), and the build without
    # range checks (sys.exudynFast, set before exudyn is imported).
    settings.linearSolver.solverType = exu.LinearSolverType.EigenDense
    settings.timeIntegration.newton.useModifiedNewton = True
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = end_time / n_steps
    settings.show.statistics = False
    settings.show.computationTime = False
    return exu, mbs, settings, sensors, keep


def run_exudyn(mech, start, n_steps):
    exu, mbs, settings, sensors, keep = build_exudyn(mech, start, n_steps, n_steps / FS)
    exu.SolveDynamic(mbs, settings)
    columns = []
    for sensor in sensors[:len(mech.joints)]:
        data = mbs.GetSensorStoredData(sensor)  # time, fx, fy, fz
        columns += [-data[:, 1], -data[:, 2]]
    for sensor in sensors[len(mech.joints):]:
        data = mbs.GetSensorStoredData(sensor)
        columns.append(-data[:, 1])
    del keep
    return data[:, 0], np.stack(columns, axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", choices=["default", "1"], default="default")
    parser.add_argument("--outputs", choices=["forces", "all"], default="forces",
                        help="what rigval returns: the joint forces and drive torques (what the "
                             "Exudyn run records) or every output (also positions, velocities, "
                             "accelerations of bodies and points)")
    args = parser.parse_args()
    sys.exudynFast = True  # the exudynCPPfast module: no range checks
    import exudyn

    mech = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
    t = np.arange(args.steps) / FS
    load0 = os.getloadavg()[0]
    blas = ("OPENBLAS_NUM_THREADS=1" if args.threads == "1" else
            "default BLAS threads (" + (os.environ.get("OPENBLAS_NUM_THREADS") or "not set") + ")")
    print(f"pendulum.toml, {args.steps} steps at {FS:g} Hz; rigval with {blas}; Exudyn "
          f"{exudyn.__version__}; load average {load0:.2f} on {os.cpu_count()} cores")

    outputs = FORCES if args.outputs == "forces" else None
    first_start = time.perf_counter()
    rm.solve(mech, t, outputs=outputs)  # a fresh process's first call, in nothing below
    first = time.perf_counter() - first_start
    start = rm.solve(mech, t[:1])
    ours_walls, exu_walls, ours_cpus, exu_cpus = [], [], [], []
    for _ in range(args.repeats):  # interleaved, so that both see the same machine load
        ours, wall, cpu = timed(lambda: rm.solve(mech, t, outputs=outputs))
        ours_walls.append(wall)
        ours_cpus.append(cpu)
        (exu_time, exu_forces), wall, cpu = timed(lambda: run_exudyn(mech, start, args.steps))
        exu_walls.append(wall)
        exu_cpus.append(cpu)
    ours_wall, exu_wall = min(ours_walls), min(exu_walls)
    ours_cpu, exu_cpu = min(ours_cpus), min(exu_cpus)
    ratios = np.array(exu_walls) / np.array(ours_walls)
    load1 = os.getloadavg()[0]

    picked = np.arange(0, args.steps, STRIDE)
    reference = forces_of(rm.solve_stepwise(mech, t[picked]))
    ours_err = rel_error(forces_of(ours)[picked], reference)
    # Exudyn's sensors record after each step: row k is t = (k + 1) / FS (row 0 of the
    # stored data is the initial state at t = 0 when present).
    exu_at = {round(v * FS): i for i, v in enumerate(exu_time)}
    rows = [exu_at.get(int(k)) for k in picked]
    have = np.array([r is not None for r in rows])
    exu_err = rel_error(exu_forces[[r for r in rows if r is not None]], reference[have])

    print(f"{'solver':36s} {'wall s':>8s} {'cpu s':>8s} {'steps/s':>10s} "
          f"{'force error / peak':>19s}")
    print(f"{'rigval.model.solve (first call)':36s} {first:8.3f} {'':8s} "
          f"{args.steps / first:10,.0f}")
    name = f"rigval.model.solve, {args.outputs} outputs"
    print(f"{name:36s} {ours_wall:8.3f} {ours_cpu:8.3f} "
          f"{args.steps / ours_wall:10,.0f} {ours_err:19.1e}")
    print(f"{'Exudyn SolveDynamic':36s} {exu_wall:8.3f} {exu_cpu:8.3f} "
          f"{args.steps / exu_wall:10,.0f} {exu_err:19.1e}")
    print(f"ratio Exudyn / rigval wall time: {exu_wall / ours_wall:.1f} (best against best); "
          f"per repeat {', '.join(f'{r:.1f}' for r in ratios)}; CPU time: "
          f"{exu_cpu / ours_cpu:.1f}; load average after {load1:.2f}")


if __name__ == "__main__":
    main()
