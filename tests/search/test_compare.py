"""Two-sample tests at the sizes evolution studies have: exact p values by enumeration."""

import math

import numpy as np
import pytest

from mjregen.search.compare import compare_groups


def test_three_runs_against_two_cannot_reject_whatever_the_values():
    """C(5, 2) = 10 splits: the most separated groups still give U's p = 2/10 (and the
    means' 1/10: the mirror split, b on top, separates the means less)."""
    result = compare_groups([39.1, 36.7, 33.3], [25.1, 24.7])
    assert result.exact and result.sizes == (3, 2) and result.u == 6.0
    assert result.p_mann_whitney == pytest.approx(0.2) == result.smallest_p
    assert result.p_permutation == pytest.approx(0.1)
    assert "the smallest Mann-Whitney p these sizes allow: 0.2" in result.sentence(("ff", "lstm"))


def test_well_separated_groups_of_eight_reject_and_overlapping_ones_do_not():
    rng = np.random.default_rng(0)
    low, high = rng.normal(0.0, 1.0, 8), rng.normal(5.0, 1.0, 8)
    separated = compare_groups(high, low)
    assert separated.u == 64.0
    assert separated.p_mann_whitney == pytest.approx(2 / math.comb(16, 8))  # 1.6e-4
    assert separated.p_permutation < 0.001
    same = compare_groups(rng.normal(0.0, 1.0, 8), rng.normal(0.0, 1.0, 8))
    assert same.p_mann_whitney > 0.05 and same.p_permutation > 0.05


def test_the_exact_p_of_a_known_case():
    """a = (1, 3), b = (2, 4): U = 1 of 4; the splits' U are 0,1,2,2,3,4, so |U - 2| >= 1
    in 4 of 6: p = 2/3. Means differ by 1; |gap| >= 1 in 4 of 6 splits as well."""
    result = compare_groups([1.0, 3.0], [2.0, 4.0])
    assert result.u == 1.0
    assert result.p_mann_whitney == pytest.approx(4 / 6)
    assert result.p_permutation == pytest.approx(4 / 6)


def test_large_groups_draw_random_splits_with_a_seed():
    rng = np.random.default_rng(1)
    a, b = rng.normal(0.0, 1.0, 15), rng.normal(1.5, 1.0, 15)
    first, again = compare_groups(a, b), compare_groups(a, b)
    assert not first.exact and first == again
    assert first.p_mann_whitney < 0.01


@pytest.mark.parametrize("a, b", [([], [1.0]), ([1.0], [np.nan]), ([np.inf], [1.0])])
def test_empty_or_non_finite_groups_are_refused(a, b):
    with pytest.raises(ValueError):
        compare_groups(a, b)
