"""Where two walks part: a robot's displacement and floor contacts over time, in mjregen and
in the paper's engine.

A walk's distance is one number at its end; a timeline samples the walk at several times,
measured as the distance is (the planar centre of mass from the end of the settle). Two
simulators that agree up to a time and part after it point at what happens then, e.g. a
robot that falls over (its voxels on the floor jump), and falls another way in the other.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import PAPER_TIMES, Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulation_of
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine


@dataclass(frozen=True)
class TimelinePoint:
    """A walk at one time.

    Attributes:
      time: s from the start (the settle included).
      distance: voxel lengths, planar displacement of the centre of mass since the settle.
      dy: voxel lengths, its y component.
      on_floor: voxels touching the floor: in mjregen, those whose centre is lower than half a
        voxel length; in the engine, its own count (``NumTouchingFloor``).
      height: voxel lengths, the centre of mass above the floor (mjregen only; None from the
        engine).
    """

    time: float
    distance: float
    dy: float
    on_floor: int
    height: float | None = None

    def to_json(self) -> dict:
        return asdict(self)


def check_times(times: Sequence[float], settle: float) -> list[float]:
    """`times` as floats, or MjregenError unless they are finite, increasing and after the
    settle (`settle` s), where the distance is measured from."""
    out = [float(t) for t in times]
    if not out:
        raise MjregenError("a timeline needs at least one time")
    if not all(math.isfinite(t) and t > settle for t in out):
        raise MjregenError(f"timeline times must be finite and after the settle ({settle:g} s), "
                           f"got {out}")
    if any(b <= a for a, b in zip(out, out[1:])):
        raise MjregenError(f"timeline times must increase, got {out}")
    return out


def mjregen_timeline(robot: Robot, times: Sequence[float], *, physics: Physics | None = None,
                     start: int = 0) -> list[TimelinePoint]:
    """The walk of `robot` from its start `start` at each of `times` (s from the start),
    stepped as `mjregen.physics.simulation.walk` steps it: the point at the settle plus the
    measured time is `simulate`'s distance exactly.

    Raises:
      MjregenError: `times` not increasing after the settle, or the walk became unstable
        (naming when and why).
    """
    physics = Physics() if physics is None else physics
    compiled = compile_robot(robot, physics=physics, starts=(start,))
    settle, _ = physics.scene.timing(robot.dim)
    times = check_times(times, settle)
    dt, length = compiled.timestep, physics.scene.voxel_size
    n_settle = round(settle / dt)
    sim = simulation_of(compiled, start)
    points, begin = [], None
    for t in [settle, *times]:
        reason = sim.run(n_settle + round((t - settle) / dt) - sim.steps)
        if reason:
            raise MjregenError(f"the walk became unstable before {t:g} s: {reason}")
        com = sim.com()
        if begin is None:
            begin = com
            continue
        heights = sim.data.xpos[compiled.body_ids, 2]
        shift = (com - begin) / length
        planar = shift[:2] if robot.dim == 3 else shift[:1]
        points.append(TimelinePoint(
            time=t, distance=float(np.linalg.norm(planar)),
            dy=float(shift[1]) if robot.dim == 3 else 0.0,
            on_floor=int(np.sum(heights < 0.5 * length)), height=float(com[2] / length)))
    return points


def engine_timeline(engine: PaperEngine, robot: Robot,
                    times: Sequence[float]) -> list[TimelinePoint]:
    """The paper's engine's walk of a 3D `robot` at each of `times` (s from the start), one
    run of the engine per time at the paper's step fraction, measured from the paper's 3D
    settle.

    Raises:
      MjregenError: a 2D robot, `times` not increasing after the settle, or the engine's
        answer lacks its y distance or floor count.
    """
    if robot.dim != 3:
        raise MjregenError("the paper's engine runs 3D robots; this one is 2D")
    settle = PAPER_TIMES[3][0]
    points = []
    for t in check_times(times, settle):
        answer = engine.run_window(robot.grid, dt_fraction=PAPER_DT_FRACTION, stop=t,
                                   measure_from=settle)
        if answer.get("dy") is None or answer.get("on_floor") is None:
            raise MjregenError("the engine's fitness file has no finalDistY or NumTouchingFloor")
        points.append(TimelinePoint(time=t, distance=answer["distance"], dy=answer["dy"],
                                    on_floor=int(answer["on_floor"])))
    return points
