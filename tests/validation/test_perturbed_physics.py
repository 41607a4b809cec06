"""`benchmarks/perturbed_physics.py`: each variant changes one part of the physics by the
amount asked, and the summary ranks and compares what it is given."""

from __future__ import annotations

import numpy as np
import pytest

from mjregen.grid import Material
from mjregen.physics import Physics

from repo_modules import load_module

perturbed = load_module("benchmarks/perturbed_physics.py")


def test_each_variant_changes_one_part_of_the_physics_by_the_amount_asked():
    base = Physics()
    found = perturbed.variants(0.05, 0.03)
    assert found["default"] == base and len(found) == 7
    soft = Material.SOFT
    assert found["E x0.95"].materials[soft].youngs_modulus == pytest.approx(
        0.95 * base.materials[soft].youngs_modulus)
    assert found["E x0.95"].materials[soft].friction == base.materials[soft].friction
    assert found["mu x1.05"].materials[Material.HARD].kinetic_friction == pytest.approx(
        1.05 * base.materials[Material.HARD].kinetic_friction)
    assert found["mu x1.05"].materials[soft].youngs_modulus == base.materials[soft].youngs_modulus
    radius = base.pipeline.collision_radius
    assert found[f"collision r {radius + 0.03:g}"].pipeline.collision_radius == pytest.approx(
        radius + 0.03)
    assert found[f"collision r {radius + 0.03:g}"].materials == base.materials


def test_the_summary_compares_the_spreads_and_ranks_against_the_engine():
    def row(name, transfers, engine, walks):
        values = np.array(walks)
        return {"name": name, "voxels": 10, "transfers": transfers, "engine": engine,
                "walks": dict(zip("abc", walks)), "spread": values.std() / values.mean(),
                "lowest_share": values.min() / values[0]}
    rows = [row("t1", True, 30.0, [30, 30, 31]), row("t2", True, 20.0, [20, 21, 20]),
            row("f1", False, 2.0, [25, 5, 20]), row("f2", False, 1.0, [10, 2, 12])]
    text = "\n".join(perturbed.summary(rows))
    assert "robots that transfer" in text and "U = 0" in text  # every spread apart
    # default walks rank 4, 2, 3, 1 against the engine's 4, 3, 2, 1 (rho 0.8); the lowest as it
    assert "the default distance 0.80" in text and "the lowest 1.00" in text
    assert perturbed.spearman(np.array([1.0, 2.0, 3.0]), np.array([3.0, 2.0, 1.0])) == -1.0
