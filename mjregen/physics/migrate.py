"""Physics descriptions written by earlier mjregen versions -> today's format, in one place.

A description (`Physics.to_dict`) carries ``"format"``. Format 4: the shared scene and one
pipeline with its parameters, the voxel pipeline's beam law and damping, friction stop
rule, collision constants and exclusion, and drag law. Format 5: the scene's start shift
(every voxel's seeded offset at the start). Format 6: the scene's settle rest (the settle
ends once the robot is at rest). `migrate_physics` brings format 4 and later to
`PHYSICS_FORMAT` step by step, stating what each step assumes, so that an old run resumes,
and an old walker replays, with exactly the physics it was evolved with. Formats 1-3 (and
descriptions without a format, format 1) are refused: the mjregen at git tag
`REPLAYS_FORMATS_1_TO_3` replays them.
"""

import copy

from mjregen.errors import PhysicsParameterError

PHYSICS_FORMAT = 6


# the last mjregen (a git tag) that reads physics descriptions of formats 1-3
REPLAYS_FORMATS_1_TO_3 = "physics-formats-1-3"
OLDEST_FORMAT = 4


def _format_4_to_5(description: dict) -> dict:
    """Format 4 -> 5: every walk started with each voxel exactly at its grid position
    (start shift 0)."""
    return {**description, "scene": {**description["scene"], "start_shift": 0.0}}


def _format_5_to_6(description: dict) -> dict:
    """Format 5 -> 6: the settle rest unset ("the body decides", which for every robot but a
    sheet is the full settle, what format 5 did; a sheet's task reads its format:
    `mjregen.tasks.locomotion.LocomotionTask.from_config`)."""
    return {**description, "scene": {**description["scene"], "settle_rest": None}}


_STEPS = {4: _format_4_to_5, 5: _format_5_to_6}


def migrate_physics(description: dict) -> dict:
    """A copy of `description` (a `Physics.to_dict` of any format) in `PHYSICS_FORMAT`.

    Raises:
      PhysicsParameterError: not a physics description, a format older than OLDEST_FORMAT
        (naming the version that reads it) or newer than this mjregen knows.
    """
    if not isinstance(description, dict) or not isinstance(description.get("scene"), dict) \
            or not isinstance(description.get("materials"), dict):
        raise PhysicsParameterError(f"invalid physics description: {description!r:.200}")
    out = copy.deepcopy(description)
    version = out.pop("format", 1)
    if isinstance(version, int) and 1 <= version < OLDEST_FORMAT:
        raise PhysicsParameterError(
            f"physics description format {version} (written before the paper engine's laws "
            f"were the voxel pipeline's options): this mjregen reads formats {OLDEST_FORMAT} "
            f"to {PHYSICS_FORMAT}; the mjregen at git tag {REPLAYS_FORMATS_1_TO_3} "
            f"(`git checkout {REPLAYS_FORMATS_1_TO_3}`) replays it")
    if not isinstance(version, int) or version < 1 or version > PHYSICS_FORMAT:
        raise PhysicsParameterError(
            f"physics description format {version!r}: this mjregen reads formats "
            f"{OLDEST_FORMAT} to {PHYSICS_FORMAT} (a newer mjregen wrote it?)")
    while version < PHYSICS_FORMAT:
        out = _STEPS[version](out)
        version += 1
    out["format"] = PHYSICS_FORMAT
    return out
