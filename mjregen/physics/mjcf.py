"""Robot arrays -> `mujoco.MjSpec`: the bodies, and the voxel plugin or MuJoCo's tendons.

Every voxel is a body ``voxel_<x>_<y>_<z>`` (2D ``voxel_<x>_<z>``) with a box geom of edge L,
its mass and the material of its voxel (``soft``, ``hard``, ``muscle_plus``,
``muscle_minus``, in the paper's colours); in 3D it has a free joint, in 2D it moves in the
x–z plane (slide x, slide z, hinge y); clamped voxels have no joint (welded to the world).

- Voxel pipeline: one instance of the engine plugin ``mjregen.voxels`` whose configuration
  holds everything its forces need (`add_voxel_plugin`: voxel bodies, muscle phases and
  strains, bonds, the floor, self-collision, drag, the muscles' frequency and start); MuJoCo's
  contacts and constraints are disabled. Numbers are written exactly (shortest repr).
- Pure-MuJoCo pipeline: each bond's tendons between sites fixed in the two bodies, contacts
  with the floor as explicit pairs, collision spheres and exclusions for self-collision,
  viscosity for the drag (`add_mujoco_bonds`).
"""

from __future__ import annotations

import math
from typing import Iterable

import mujoco
import numpy as np

from mjregen.grid import Material
from mjregen.physics import voxel_plugin
from mjregen.physics.model import (
    RobotBonds,
    RobotLayout,
    collision_constants,
    drag_viscosity,
    engine_floor_constants,
    near_pairs,
    voxel_drag,
)
from mjregen.physics.params import REST_WINDOW, Physics
from mjregen.physics.pipelines import POINT_RADIUS
from mjregen.physics.rounding import round_like_mjcf
from mjregen.physics.tendons import BondTable

FLOOR = "floor"
POINT_FLOOR = "floor_centres"  # contact_shape "point": the plane that voxel centres touch
PLUGIN_INSTANCE = "robot"  # the voxel plugin's instance name in the model
COLLISION_SKIN = 0.5  # Verlet-list skin of the plugin's self-collision, in voxel lengths
MATERIAL_NAMES = {Material.SOFT: "soft", Material.HARD: "hard",
                  Material.MUSCLE_PLUS: "muscle_plus", Material.MUSCLE_MINUS: "muscle_minus"}
MATERIAL_RGBA: dict[Material, tuple[float, float, float, float]] = {  # the paper's colours
    Material.SOFT: (0.55, 0.80, 1.00, 1.0),  # light blue
    Material.HARD: (0.10, 0.22, 0.75, 1.0),  # dark blue
    Material.MUSCLE_PLUS: (0.90, 0.15, 0.15, 1.0),  # red
    Material.MUSCLE_MINUS: (0.20, 0.75, 0.25, 1.0),  # green
}
DRIVES = ("waveform", "ctrl")


def voxel_bodies(layout: RobotLayout, physics: Physics) -> tuple[mujoco.MjSpec, list]:
    """A spec with options, materials, the floor plane and one body per voxel."""
    scene = physics.scene
    L = scene.voxel_size
    spec = mujoco.MjSpec()
    spec.modelname = "mjregen_robot"
    spec.option.gravity = round_like_mjcf([0.0, 0.0, -scene.gravity])
    spec.option.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                              "rk4": mujoco.mjtIntegrator.mjINT_RK4}[physics.pipeline.integrator]
    for material, name in MATERIAL_NAMES.items():
        spec.add_material(name=name, rgba=list(MATERIAL_RGBA[material]))
    if scene.floor:
        spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[0.0, 0.0, L], contype=0, conaffinity=0)
    bodies = []
    for i, ((index, material), name, centre) in enumerate(zip(layout.voxels, layout.names,
                                                              layout.centres)):
        body = spec.worldbody.add_body(name=name, pos=round_like_mjcf(centre))
        if index not in layout.clamped:
            _add_joints(body, layout.dim)
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=round_like_mjcf([L / 2] * 3),
                      mass=round_like_mjcf(layout.masses[i]), contype=0, conaffinity=0,
                      material=MATERIAL_NAMES[material])
        bodies.append(body)
    return spec, bodies


def _numbers(values: Iterable) -> str:
    """Plugin configuration text: numbers written exactly (shortest round-trip repr;
    integers and flags as integers)."""
    array = np.asarray(values).ravel()
    if array.dtype == np.bool_:
        array = array.astype(np.int64)
    return " ".join(map(repr, array.tolist()))


def plugin_config(layout: RobotLayout, physics: Physics, bonds: RobotBonds,
                  drive: str) -> dict[str, str]:
    """The voxel plugin instance's configuration (attribute -> text): every number it needs,
    written exactly."""
    scene, pipeline = physics.scene, physics.pipeline
    L = scene.voxel_size
    props = [physics.materials[m] for _, m in layout.voxels]
    beams, table = bonds.beams, bonds.tendons
    floor_stiffness, floor_damping = engine_floor_constants(layout, physics)
    settle, _ = scene.timing(layout.dim)
    n_bonds = len(layout.bonds)
    weights = np.zeros((n_bonds, 2))
    weights[: len(beams.muscle_weights)] = beams.muscle_weights
    collision_stiffness, collision_damping = collision_constants(layout, physics)
    drag_linear, drag_rotational = voxel_drag(layout, physics)
    grid3 = np.zeros((len(layout.voxels), 3), dtype=int)
    grid3[:, 3 - layout.dim:] = layout.grid_index
    beam = pipeline.bond_element == "beam"
    config = {
        "dim": str(layout.dim), "voxel_size": repr(L),
        "voxels": " ".join(layout.names),
        "frequency": repr(scene.frequency), "start": repr(float(settle)),
        "waveform": scene.waveform, "drive": drive,
        "phase": _numbers([p.phase_sign for p in props]),
        "strain": _numbers([p.strain_amplitude for p in props]),
        "element": "beam" if beam else "tendons",
        "bonds": _numbers(beams.ends), "bond_axis": _numbers(beams.axis),
        "bond_muscle": _numbers(weights),
        "floor": str(int(scene.floor)),
        "floor_stiffness": _numbers(floor_stiffness),
        "floor_damping": _numbers(floor_damping),
        "static_friction": _numbers([p.friction for p in props]),
        "kinetic_friction": _numbers([p.friction if p.kinetic_friction is None
                                      else p.kinetic_friction for p in props]),
        "friction_stop": pipeline.friction_stop,
        "friction_stop_time": repr(pipeline.friction_stop_time or 0.0),
        "collision_radius": repr(pipeline.collision_radius * L),
        "collision_skin": repr(COLLISION_SKIN * L),
        "collision_stiffness": _numbers(collision_stiffness),
        "collision_damping": _numbers(collision_damping),
        "collision_hops": str(pipeline.collision_hops),
        "grid": _numbers(grid3), "collides": _numbers(layout.surface.astype(int)),
        "drag_linear": _numbers(drag_linear), "drag_rotational": _numbers(drag_rotational),
    }
    if scene.rest_threshold > 0.0:
        config["settle_rest"] = _numbers([scene.rest_threshold, REST_WINDOW])
    if beam:
        config.update(bond_stiffness=_numbers(beams.stiffness),
                      bond_axial_law=_numbers(beams.axial_law), bond_beta=_numbers(beams.beta))
    else:
        config.update(tendon_bond=_numbers(table.bond), tendon_sites=_numbers(table.offsets),
                      tendon_stiffness=_numbers(table.stiffness),
                      tendon_damping=_numbers(table.damping), tendon_rest=_numbers(table.rest),
                      tendon_lateral2=_numbers(table.lateral ** 2))
    return config


def add_voxel_plugin(spec: mujoco.MjSpec, layout: RobotLayout, physics: Physics,
                     bonds: RobotBonds, drive: str) -> None:
    """The ``mjregen.voxels`` instance that computes every force (contacts and constraints
    of MuJoCo off), and with drive "ctrl" the two strain actuators."""
    L = physics.scene.voxel_size
    config = plugin_config(layout, physics, bonds, drive)
    unknown = set(config) - set(voxel_plugin.ATTRIBUTES)
    if unknown:
        raise AssertionError(f"voxel plugin attributes unknown to the plugin: {sorted(unknown)}")
    spec.activate_plugin(voxel_plugin.PLUGIN_NAME)
    instance = spec.add_plugin(name=PLUGIN_INSTANCE, plugin_name=voxel_plugin.PLUGIN_NAME, active=True)
    instance.config = config
    if drive == "ctrl":
        spec.worldbody.add_site(name="muscles", size=[L / 10, 0.0, 0.0], group=4)
        for name in ("muscle_plus", "muscle_minus"):
            spec.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_SITE, target="muscles",
                              gainprm=[0.0] * 10, biasprm=[0.0] * 10, ctrllimited=True,
                              ctrlrange=[-1.0, 1.0])
    # the plugin is every force: MuJoCo has no contact or constraint to find or solve
    spec.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                                 | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)


def add_mujoco_bonds(spec: mujoco.MjSpec, bodies: list, layout: RobotLayout,
                     physics: Physics, table: BondTable) -> None:
    """Pure MuJoCo: bond tendons with sites, MuJoCo contacts with the floor, collision
    spheres and exclusions for self-collision, viscosity for the drag."""
    scene, pipeline = physics.scene, physics.pipeline
    L = scene.voxel_size
    spec.option.viscosity = drag_viscosity(physics)
    point = pipeline.contact_shape == "point"
    floor_geom = FLOOR
    if scene.floor and point:
        # the engine's floor acts on voxel centres lower than L/2: a hidden plane there
        floor_geom = POINT_FLOOR
        spec.worldbody.add_geom(name=POINT_FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[0.0, 0.0, L], contype=0, conaffinity=0, group=3,
                                pos=[0.0, 0.0, round_like_mjcf(L / 2 - POINT_RADIUS * L)])
    for i, ((index, material), body) in enumerate(zip(layout.voxels, bodies)):
        name = body.name
        props = physics.materials[material]
        solref, solimp = _contact_solver(physics, props, layout.masses[i])
        contact_geom = name
        radius = pipeline.collision_radius
        collide = int(radius > 0.0 and layout.surface[i])
        # contact geoms are massless and hidden (group 3): the box keeps mass, inertia, looks
        if pipeline.contact_shape == "sphere" or (collide and radius == 0.5):
            # one sphere of radius L/2 serves the floor ("sphere") and self-collision
            contact_geom = "c" + name
            body.add_geom(name=contact_geom, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=round_like_mjcf([L / 2, 0.0, 0.0]), mass=0.0,
                          contype=int(collide and radius == 0.5),
                          conaffinity=int(collide and radius == 0.5),
                          condim=1, group=3, solref=solref, solimp=solimp)
        if collide and radius != 0.5:
            body.add_geom(name="s" + name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=round_like_mjcf([radius * L, 0.0, 0.0]), mass=0.0,
                          contype=1, conaffinity=1, condim=1, group=3, solref=solref,
                          solimp=solimp)
        if point:
            contact_geom = "p" + name
            body.add_geom(name=contact_geom, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=round_like_mjcf([POINT_RADIUS * L, 0.0, 0.0]), mass=0.0, contype=0,
                          conaffinity=0, group=3)
        if scene.floor and index not in layout.clamped:
            spec.add_pair(geomname1=floor_geom, geomname2=contact_geom, condim=3,
                          friction=round_like_mjcf([props.friction, props.friction, 0.0, 0.0, 0.0]),
                          solref=solref, solimp=solimp)
    if pipeline.collision_radius > 0.0:
        for i, j in near_pairs(layout.grid_index, layout.index_of):
            spec.add_exclude(bodyname1=bodies[i].name, bodyname2=bodies[j].name)
    sites: dict[tuple[int, tuple[float, ...]], str] = {}
    for t in range(table.count):
        i, j = table.ends[t]
        tendon = spec.add_tendon(name=f"bond{table.bond[t]}_{t}")
        tendon.wrap_site(_site(bodies[i], int(i), tuple(table.offsets[t, 0]), sites))
        tendon.wrap_site(_site(bodies[j], int(j), tuple(table.offsets[t, 1]), sites))
        tendon.stiffness = [float(table.stiffness[t]), 0.0, 0.0]
        tendon.damping = [float(table.damping[t]), 0.0, 0.0]
        tendon.springlength = [float(table.rest[t])] * 2


def _contact_solver(physics: Physics, props, mass: float) -> tuple[list[float], list[float]]:
    """(solref, solimp) of a voxel's contacts.

    Without `contact_stiffness`: the pipeline's time constant, damping ratio and width. With
    it: MuJoCo's direct form solref = (−k/m, −c/m), a spring k = contact_stiffness·E·L and a
    damper c = contact_damping·2 sqrt(m E L) per contact, with a constant impedance 0.99
    so the contact acts as that spring–damper on the voxel's mass.
    """
    pipeline = physics.pipeline
    if pipeline.contact_stiffness is None:
        return (round_like_mjcf([pipeline.contact_timeconst, pipeline.contact_dampratio]),
                round_like_mjcf([0.9, 0.95, pipeline.contact_width, 0.5, 2.0]))
    EL = props.youngs_modulus * physics.scene.voxel_size
    k = pipeline.contact_stiffness * EL
    c = pipeline.contact_damping * 2.0 * math.sqrt(mass * EL)
    return (round_like_mjcf([-k / mass, -c / mass]),
            round_like_mjcf([0.99, 0.99, pipeline.contact_width, 0.5, 2.0]))


def _add_joints(body: mujoco.MjsBody, dim: int) -> None:
    """Free joint in 3D; slide x, slide z, hinge y in 2D."""
    if dim == 3:
        body.add_freejoint()
        return
    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])


def _site(body: mujoco.MjsBody, voxel: int, offset: tuple[float, ...],
          sites: dict[tuple[int, tuple[float, ...]], str]) -> str:
    """Name of the site at `offset` in `body`, added on first use."""
    key = (voxel, tuple(round(x, 15) for x in offset))
    if key not in sites:
        sites[key] = f"s{len(sites)}"
        body.add_site(name=sites[key], pos=round_like_mjcf(offset))
    return sites[key]
