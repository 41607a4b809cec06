"""Physics descriptions written by any mjregen version -> today's format, in one place.

A description (`Physics.to_dict`) carries ``"format"``; one without it is format 1 (run
folders and asset manifests written before formats were recorded: one flat scene, fields
added later missing). Format 2: the same flat scene, complete. Format 3: the shared scene
and one pipeline with its parameters. Format 4: the voxel pipeline's beam law and damping,
friction stop rule, collision constants and exclusion, and drag law. Format 5: the scene's
start shift (every voxel's seeded offset at the start). Format 6: the scene's settle rest
(the settle ends once the robot is at rest). `migrate_physics` brings
any format to `PHYSICS_FORMAT` step by step, stating what each step assumes, so that an old
run resumes, and an old walker replays, with exactly the physics it was evolved with.
"""

from __future__ import annotations

import copy

from mjregen.errors import PhysicsParameterError

PHYSICS_FORMAT = 6


# format 1: one flat scene; a field missing from a description took the value below (the
# defaults of the scene class then), except the three that were added later
_FORMAT_1_DEFAULTS = {
    "voxel_size": 1e-3, "gravity": 27.468, "frequency": 40.0, "waveform": "contract",
    "settle_time": None, "measured_time": None, "bond_damping_ratio": 0.4,
    "integrator": "euler", "timestep_safety": 0.75, "floor": True, "contact_timeconst": 3e-4,
    "contact_dampratio": 1.0, "contact_width": 1e-5, "bond_model": "euler_bernoulli",
    "drag_ratio": 0.001, "contact_shape": "engine", "contact_stiffness": 2.0,
    "contact_damping": 0.8, "self_collision": True, "damp_strain_rate": False,
    "collision_radius": 0.625,
    "bond_element": "tendons",  # before beam bonds: 8 tendons per bond
    "stepper": "mujoco",  # before the fast path: mj_step (the same motion to rounding)
    "timestep_rule": "stiffest_bond",  # before the network rule
}
_SHARED = ("voxel_size", "gravity", "frequency", "waveform", "settle_time", "measured_time",
           "bond_damping_ratio", "drag_ratio", "floor", "timestep_safety")


def _format_1_to_2(description: dict) -> dict:
    """Format 1 -> 2: missing fields take the values they had (`_FORMAT_1_DEFAULTS`); how
    bonds were computed (`bond_backend`: MuJoCo tendons or the same forces in C) and the
    strain-rate drive are gone."""
    unknown = set(description["scene"]) - set(_FORMAT_1_DEFAULTS) - {"bond_backend"}
    if unknown:
        raise PhysicsParameterError(f"unknown scene fields {sorted(unknown)}")
    scene = {**_FORMAT_1_DEFAULTS, **description["scene"]}
    scene.pop("bond_backend", None)
    if scene.pop("damp_strain_rate"):
        raise PhysicsParameterError(
            "this physics description damps the muscles' strain rate (damp_strain_rate), "
            "which mjregen no longer models")
    return {**description, "scene": scene}


def _format_2_to_3(description: dict) -> dict:
    """Format 2's flat scene -> the shared scene and a pipeline: contact shape "engine" was
    the voxel plugin's floor (then computed in a passive callback: the same forces), any
    other shape the pure-MuJoCo model."""
    old = description["scene"]
    missing = set(_FORMAT_1_DEFAULTS) - {"damp_strain_rate"} - set(old)
    if missing:
        raise PhysicsParameterError(f"scene fields missing: {sorted(missing)}")
    radius = old["collision_radius"] if old["self_collision"] else 0.0
    if old["contact_shape"] == "engine":
        if old["integrator"] != "euler":
            raise PhysicsParameterError("the engine floor was only ever stepped with Euler")
        pipeline = {"name": "voxel", "bond_element": old["bond_element"],
                    "bond_model": old["bond_model"],
                    "floor_stiffness": old["contact_stiffness"],
                    "floor_damping": old["contact_damping"], "collision_radius": radius,
                    "timestep_rule": old["timestep_rule"], "stepper": old["stepper"]}
    else:
        if old["bond_element"] == "beam":
            raise PhysicsParameterError(
                "beam bonds with MuJoCo contacts are no longer a model mjregen has (beams are "
                "the voxel plugin's, with the engine floor)")
        pipeline = {"name": "mujoco", "contact_shape": old["contact_shape"],
                    "bond_model": old["bond_model"],
                    "contact_stiffness": old["contact_stiffness"],
                    "contact_damping": old["contact_damping"],
                    "contact_timeconst": old["contact_timeconst"],
                    "contact_dampratio": old["contact_dampratio"],
                    "contact_width": old["contact_width"], "collision_radius": radius,
                    "integrator": old["integrator"], "timestep_rule": old["timestep_rule"]}
    return {"materials": description["materials"],
            "scene": {key: old[key] for key in _SHARED}, "pipeline": pipeline}


def _format_3_to_4(description: dict) -> dict:
    """Format 3 -> 4: a voxel pipeline without the fields of format 4 had the rules that
    are now its options: beams with the tendons' axial law and torsion, stiffness-
    proportional damping, sliding stopped by the energy test, self-collision with the
    floor's spring and damper, grid neighbours excluded, one Stokes drag for all voxels."""
    pipeline = dict(description["pipeline"])
    if pipeline.get("name") == "voxel":
        added = {"beam_law": "tendons", "beam_damping": "stiffness_proportional",
                 "friction_stop": "energy", "friction_stop_time": None,
                 "collision_stiffness": pipeline.get("floor_stiffness", 2.0),
                 "collision_damping": pipeline.get("floor_damping", 0.8),
                 "collision_hops": 0, "drag_law": "stokes",
                 "collision_radius": pipeline.get("collision_radius", 0.625)}
        pipeline = {**pipeline, **{k: v for k, v in added.items() if k not in pipeline}}
    return {**description, "pipeline": pipeline}


def _format_4_to_5(description: dict) -> dict:
    """Format 4 -> 5: every walk started with each voxel exactly at its grid position
    (start shift 0)."""
    return {**description, "scene": {**description["scene"], "start_shift": 0.0}}


def _format_5_to_6(description: dict) -> dict:
    """Format 5 -> 6: the settle rest unset ("the body decides", which for every robot but a
    sheet is the full settle, what format 5 did; a sheet's task reads its format:
    `mjregen.tasks.locomotion.LocomotionTask.from_config`)."""
    return {**description, "scene": {**description["scene"], "settle_rest": None}}


_STEPS = {1: _format_1_to_2, 2: _format_2_to_3, 3: _format_3_to_4, 4: _format_4_to_5,
          5: _format_5_to_6}


def migrate_physics(description: dict) -> dict:
    """A copy of `description` (a `Physics.to_dict` of any format) in `PHYSICS_FORMAT`.

    Raises:
      PhysicsParameterError: not a physics description, a format newer than this mjregen
        knows, or a setting that no longer exists.
    """
    if not isinstance(description, dict) or not isinstance(description.get("scene"), dict) \
            or not isinstance(description.get("materials"), dict):
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
