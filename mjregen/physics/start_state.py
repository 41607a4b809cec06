"""The start of a walk: every voxel at its grid position, moved by a seeded random offset.

A robot whose body is its own mirror image keeps that symmetry from an exact start (nothing
in the physics breaks it), so it can balance where any physical world, or the paper's engine
with its rounding, lets it fall: a one-voxel plate on its edge. Each walk therefore starts
with every voxel's translational coordinates (3D: its free joint's x, y, z; 2D: its two
slides; rotations start exact) moved by normal random offsets of standard deviation
`Scene.start_shift` voxel lengths.

A start is named by the evaluation's seed (a run's seed; 0 for a plain walk), its index
among the starts a robust score averages, and the robot's grid itself (its bytes hashed):
the same robot gets the same start in every process and on every backend, and two robots
get independent ones. The compiled model holds each start as a keyframe ``start_<index>``
(`key_name`), so the exported MJCF carries the very start `simulate` runs; its positions are
rounded as MJCF writes them (6 significant digits: steps of 1e-5 voxel lengths 1 to 10 voxel
lengths from the origin), which is why a shift is 0 or at least `MIN_START_SHIFT`.
"""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

from mjregen.physics.model import RobotLayout
from mjregen.physics.params import Scene
from mjregen.physics.rounding import round_like_mjcf

QUAT_IDENTITY = (1.0, 0.0, 0.0, 0.0)
# starts one model holds as keyframes at most (1,000 of a 343-voxel robot: about 35 MB of
# keyframes, 2 s to compile, 3 CPU minutes to walk)
MAX_STARTS = 1000


def key_name(index: int) -> str:
    """The keyframe that holds start `index` in a compiled model."""
    return f"start_{index}"


def check_start(name: str, value: object) -> int:
    """`value` as an int >= 0, or ValueError naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name} must be a whole number >= 0, got {value!r}")
    return int(value)


def start_generator(grid: np.ndarray, seed: int, index: int) -> np.random.Generator:
    """The random generator of start `index` of robot `grid` (int8 array, any shape) in the
    evaluation seeded `seed`: seeded by both numbers and a hash of the grid's shape and
    bytes, the same in every process."""
    grid = np.ascontiguousarray(grid, dtype=np.int8)
    digest = hashlib.blake2b(repr(grid.shape).encode() + grid.tobytes(), digest_size=16)
    words = np.frombuffer(digest.digest(), dtype="<u4").tolist()
    entropy = [check_start("start seed", seed), check_start("start index", index), *words]
    return np.random.default_rng(np.random.SeedSequence(entropy))


def rest_qpos(layout: RobotLayout) -> tuple[np.ndarray, np.ndarray]:
    """``(nq,)`` the joint coordinates of every voxel at its grid position (the model's
    ``qpos0``: 3D a free joint's centre and identity quaternion, 2D slides and hinge at 0;
    clamped voxels have none) and ``(nq,)`` bool, which of them are translations."""
    qpos, translational = [], []
    for (index, _), centre in zip(layout.voxels, layout.centres):
        if index in layout.clamped:
            continue
        if layout.dim == 3:
            qpos += [*round_like_mjcf(centre), *QUAT_IDENTITY]
            translational += [True] * 3 + [False] * 4
        else:  # slide x, slide z, hinge y (`mjcf._add_joints`)
            qpos += [0.0, 0.0, 0.0]
            translational += [True, True, False]
    return np.array(qpos, dtype=float), np.array(translational, dtype=bool)


def start_qpos(layout: RobotLayout, scene: Scene, grid: np.ndarray, *, seed: int,
               index: int) -> np.ndarray:
    """``(nq,)`` the joint coordinates of start `index` (module docstring): `rest_qpos` with
    normal offsets of ``scene.start_shift`` voxel lengths on the translations, rounded as
    MJCF writes numbers (the exported keyframe is the same start)."""
    qpos, translational = rest_qpos(layout)
    offsets = start_generator(grid, seed, index).normal(0.0, 1.0, int(translational.sum()))
    qpos[translational] += offsets * (scene.start_shift * scene.voxel_size)
    return np.array(round_like_mjcf(qpos))


def translational_coordinates(model: mujoco.MjModel) -> np.ndarray:
    """``(nq,)`` bool: the coordinates of `model` that are positions (free joints' x, y, z;
    slides), as `rest_qpos` marks them; for perturbing a state directly, finer than a
    keyframe holds (studies of chaos, `benchmarks/accuracy.py`)."""
    mask = np.zeros(model.nq, dtype=bool)
    for joint in range(model.njnt):
        address = model.jnt_qposadr[joint]
        if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
            mask[address:address + 3] = True
        elif model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_SLIDE:
            mask[address] = True
    return mask
