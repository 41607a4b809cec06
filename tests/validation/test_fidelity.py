"""The paper engine's reference cases re-run in mjregen (docs/fidelity.md): the small
mechanical cases and the paper's three robots.

The reference numbers are in `mjregen.validation.reference.REFERENCE` (from the engine's trajectories),
the robots' paths in `mjregen.validation.reference.ENGINE_PATHS` (shipped).
"""

import numpy as np
import pytest

from mjregen.physics import Physics, box_physics, paper_physics, sphere_physics
from mjregen.validation.reference import CASES, REFERENCE, engine_path, heading_of, path_difference


def test_paper_preset_is_the_default_and_round_trips():
    physics = paper_physics()
    assert Physics.from_dict(physics.to_dict()) == physics
    assert physics.pipeline.name == "voxel" and physics.scene.drag_ratio == 0.001
    assert physics == Physics()
    assert sphere_physics() != physics and box_physics() != physics


@pytest.mark.parametrize("case", ["slide_bar_v0.2", "slide_bar_v0.1"])
def test_default_slides_like_the_paper_engine(case):
    """Static 1.0 / kinetic 0.5 friction of the engine floor on a kicked bar: slide length
    within 2 % (measured 0.3–0.5 %), stopping time within 3 % (measured 1.3–2.3 % at the
    default step of this bar, 8.0e-5 s — the engine's own is 4.5e-5 s —, 0.3–0.8 % at the
    stiffest-bond rule's 2.8e-5 s: the stick rule stops a voxel within a step)."""
    result = CASES[case](Physics())
    assert result.measures["slide"] == pytest.approx(REFERENCE[case]["slide"], rel=0.02)
    assert result.measures["stop_after"] == pytest.approx(REFERENCE[case]["stop_after"],
                                                          rel=0.03)


def test_paper_preset_simple_cases_within_10_percent():
    """Rest height and block rebound (contact, bond damping), muscle strain, beam sag."""
    physics = paper_physics()
    block = CASES["drop_block"](physics).measures
    assert block["rest_z"] == pytest.approx(REFERENCE["drop_block"]["rest_z"], rel=0.01)
    assert block["first_apex_z"] == pytest.approx(REFERENCE["drop_block"]["first_apex_z"],
                                                  rel=0.05)
    voxel = CASES["drop_voxel"](physics).measures
    assert voxel["rest_z"] == pytest.approx(REFERENCE["drop_voxel"]["rest_z"], rel=0.01)
    bar = CASES["bar_red_green"](physics).measures
    assert bar["len_min"] == pytest.approx(REFERENCE["bar_red_green"]["len_min"], rel=0.01)
    beam = CASES["cantilever"](physics).measures
    assert beam["sag_end"] == pytest.approx(REFERENCE["cantilever"]["sag_end"], rel=0.10)


# the goal for the paper robots against the engine (mjregen.validation.reference.ENGINE_PATHS)
DISTANCE_RATIO = (0.9, 1.1)
HEADING_TOLERANCE = 10.0  # degrees
PATH_TOLERANCE = 5e-3  # m, RMS difference of the planar COM paths over the walk


@pytest.mark.parametrize("name", ["tripod", "biped", "multiped"])
def test_paper_robot_walks_as_far_and_the_same_way_as_in_the_paper_engine(name):
    """Distance within 10 %, heading within 10 degrees, planar COM path within 5 mm RMS of
    the engine's (measured: docs/fidelity.md)."""
    result = CASES[name](Physics())
    assert result.stable
    ratio = result.measures["distance"] / REFERENCE[name]["distance"]
    assert DISTANCE_RATIO[0] <= ratio <= DISTANCE_RATIO[1]
    off = (result.measures["heading"] - REFERENCE[name]["heading"] + 180.0) % 360.0 - 180.0
    assert abs(off) <= HEADING_TOLERANCE
    assert result.measures["com_rms"] <= PATH_TOLERANCE


def test_engine_paths_ship_with_the_package_and_match_the_recorded_distances():
    """The shipped engine paths are the engine's walks: their distance from the settle's end
    is the engine's fitness (to its 0.1 ms sampling) and the heading is REFERENCE's."""
    for name in ("tripod", "biped", "multiped"):
        t, com = engine_path(name)
        assert t[0] == 0.0 and t[-1] == pytest.approx(0.55) and com.shape == (len(t), 3)
        start = int(np.argmin(np.abs(t - 0.05)))
        walked = np.linalg.norm(com[-1, :2] - com[start, :2]) / 1e-3
        assert walked == pytest.approx(REFERENCE[name]["distance"], rel=2e-4)
        assert heading_of(com[start], com[-1]) == pytest.approx(REFERENCE[name]["heading"],
                                                                abs=0.01)
        assert path_difference(t, com, name, 0.05) == 0.0


def test_single_voxel_bounces_like_the_engines_once_the_step_resolves_the_contact():
    """The dropped voxel's rebound (46 µm, restitution 0.1) and deepest penetration, at a
    quarter of the default step (5.7e-6 s; the engine ran it at 1.4e-6 s): within 10 % and
    3 % of the engine's (measured 1.00 and 1.00; at the default step 0.76 and 0.94, Euler's
    error on a strongly damped contact half-cycle)."""
    physics = Physics().replace(timestep_safety=Physics().scene.timestep_safety / 4)
    voxel = CASES["drop_voxel"](physics).measures
    assert voxel["rebound"] == pytest.approx(REFERENCE["drop_voxel"]["rebound"], rel=0.10)
    assert voxel["min_zbot"] == pytest.approx(REFERENCE["drop_voxel"]["min_zbot"], rel=0.03)
