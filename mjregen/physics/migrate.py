"""Physics descriptions written by any mjregen version -> today's format, in one place.

A description (`Physics.to_dict`) carries ``"format"``; one without it is format 1 (run
folders and asset manifests written before formats were recorded). `migrate_physics` brings
any format to `PHYSICS_FORMAT` step by step, stating what each step assumes, so that an old
run resumes, and an old walker replays, with exactly the physics it was evolved with.
"""

from __future__ import annotations

import copy

from mjregen.errors import PhysicsParameterError

PHYSICS_FORMAT = 2


def _format_1_to_2(description: dict) -> dict:
    """Format 1: fields added later were absent (their old behaviour applies) and two fields
    existed that mjregen no longer has."""
    scene = description["scene"]
    scene.setdefault("bond_element", "tendons")  # before beam bonds: 8 tendons per bond
    scene.setdefault("stepper", "mujoco")  # before the fast path: mj_step (same motion)
    scene.setdefault("timestep_rule", "stiffest_bond")  # before the network rule
    # how bonds were computed (MuJoCo tendons or the same forces in C) is now the pipeline's
    # choice (contact_shape "engine": the voxel plugin; else MuJoCo tendons)
    scene.pop("bond_backend", None)
    if scene.pop("damp_strain_rate", False):
        raise PhysicsParameterError(
            "this physics description damps the muscles' strain rate (damp_strain_rate), "
            "which mjregen no longer models")
    return description


_STEPS = {1: _format_1_to_2}


def migrate_physics(description: dict) -> dict:
    """A copy of `description` (a `Physics.to_dict` of any format) in `PHYSICS_FORMAT`.

    Raises:
      PhysicsParameterError: not a physics description, a format newer than this mjregen
        knows, or a setting that no longer exists.
    """
    if not isinstance(description, dict) or not isinstance(description.get("scene"), dict):
        raise PhysicsParameterError(f"invalid physics description: {description!r:.200}")
    out = copy.deepcopy(description)
    version = out.pop("format", 1)
    if not isinstance(version, int) or version < 1 or version > PHYSICS_FORMAT:
        raise PhysicsParameterError(
            f"physics description format {version!r}: this mjregen reads formats 1 to "
            f"{PHYSICS_FORMAT} (a newer mjregen wrote it?)")
    while version < PHYSICS_FORMAT:
        out = _STEPS[version](out)
        version += 1
    out["format"] = PHYSICS_FORMAT
    return out
