"""Small reference cases of the paper's engine, re-run in mjregen (docs/fidelity.md).

The reference numbers are in `mjregen.reference.REFERENCE` (from the engine's trajectories).
"""

import pytest

from mjregen.physics import Physics, paper_physics
from mjregen.reference import CASES, REFERENCE


def test_paper_preset_round_trips_and_differs_from_default():
    physics = paper_physics()
    assert Physics.from_dict(physics.to_dict()) == physics
    assert physics.scene.contact_shape == "sphere" and physics.scene.drag_ratio == 0.001
    assert physics != Physics()


@pytest.mark.parametrize("case", ["slide_bar_v0.2", "slide_bar_v0.1"])
def test_default_slides_like_the_paper_engine(case):
    """Coulomb friction 0.5 on a kicked bar: slide length within 10 % (measured 6 %)."""
    result = CASES[case](Physics())
    assert result.measures["slide"] == pytest.approx(REFERENCE[case]["slide"], rel=0.10)


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
