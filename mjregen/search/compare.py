"""Two groups of runs compared by tests that can reject at their size: exact two-sided
Mann–Whitney U and permutation (difference of means) tests.

A bootstrap CI of two or three values is little more than their range; these tests say how
unlikely the observed separation is if the groups were exchangeable, and how small a p the
groups' sizes allow at all (3 runs against 2 cannot give a Mann–Whitney p below 0.2,
whatever the values).
Every split of the pooled values into the two groups' sizes is enumerated (exact) up to
`EXACT_SPLITS` splits; beyond that `RANDOM_SPLITS` random splits are drawn (seeded).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

EXACT_SPLITS = 200_000
RANDOM_SPLITS = 100_000
TOLERANCE = 1e-12  # relative: statistics this close to the observed one count as as extreme


@dataclass(frozen=True)
class Comparison:
    """Group a against group b.

    Attributes:
      sizes: (n_a, n_b).
      means: the groups' means.
      u: Mann–Whitney U of a (pairs with a above b, ties counting one half).
      p_mann_whitney: two-sided p of U.
      p_permutation: two-sided p of the difference of means.
      smallest_p: the smallest two-sided Mann–Whitney p any values could give at these
        sizes: 2 / C(n_a + n_b, n_a) (the permutation test's can be half that when the sizes
        differ).
      exact: every split was enumerated (else `RANDOM_SPLITS` were drawn).
    """

    sizes: tuple[int, int]
    means: tuple[float, float]
    u: float
    p_mann_whitney: float
    p_permutation: float
    smallest_p: float
    exact: bool

    def sentence(self, names: tuple[str, str] = ("a", "b")) -> str:
        """The comparison for people."""
        (na, nb), (ma, mb) = self.sizes, self.means
        how = "exact" if self.exact else f"{RANDOM_SPLITS} random splits"
        return (f"{names[0]} {ma:.4g} (n={na}) vs {names[1]} {mb:.4g} (n={nb}): Mann-Whitney "
                f"U = {self.u:g}, two-sided p = {self.p_mann_whitney:.3g}; permutation test of "
                f"the means p = {self.p_permutation:.3g} ({how}; the smallest Mann-Whitney p "
                f"these sizes allow: {self.smallest_p:.3g})")


def _u_statistic(a: np.ndarray, b: np.ndarray) -> float:
    """Pairs (a_i, b_j) with a_i > b_j, plus half the ties."""
    difference = a[:, None] - b[None, :]
    return float(np.count_nonzero(difference > 0) + 0.5 * np.count_nonzero(difference == 0))


def _mid_ranks(values: np.ndarray) -> np.ndarray:
    """Ranks 1..n of `values`, ties sharing their mean rank."""
    order = np.argsort(values, kind="stable")
    ranks = np.empty(values.size)
    ranks[order] = np.arange(1, values.size + 1)
    for value in np.unique(values):
        tied = values == value
        ranks[tied] = ranks[tied].mean()
    return ranks


def _splits(n: int, k: int, seed: int) -> tuple[np.ndarray, bool]:
    """``(splits, n)`` bool masks of group a, every split (exact) or random ones."""
    total = math.comb(n, k)
    if total <= EXACT_SPLITS:
        masks = np.zeros((total, n), dtype=bool)
        for row, chosen in enumerate(itertools.combinations(range(n), k)):
            masks[row, list(chosen)] = True
        return masks, True
    rng = np.random.default_rng(seed)
    order = np.argsort(rng.random((RANDOM_SPLITS, n)), axis=1)
    masks = np.zeros((RANDOM_SPLITS, n), dtype=bool)
    np.put_along_axis(masks, order[:, :k], True, axis=1)
    return masks, False


def _share_as_extreme(values: np.ndarray, observed: float) -> float:
    return float(np.mean(values >= observed * (1.0 - TOLERANCE) - TOLERANCE))


def compare_groups(a: np.ndarray | list[float], b: np.ndarray | list[float], *,
                   seed: int = 0) -> Comparison:
    """Compare two groups of finite values (each at least one).

    Raises:
      ValueError: an empty group or a value that is not finite.
    """
    a, b = np.asarray(a, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()
    if a.size < 1 or b.size < 1:
        raise ValueError(f"each group needs a value, got sizes {a.size} and {b.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("the groups' values must be finite")
    pooled = np.concatenate([a, b])
    masks, exact = _splits(pooled.size, a.size, seed)
    in_a = np.where(masks, pooled, 0.0)
    mean_a = in_a.sum(axis=1) / a.size
    mean_b = (pooled.sum() - in_a.sum(axis=1)) / b.size
    mean_gap = np.abs(mean_a - mean_b)
    u_all = masks @ _mid_ranks(pooled) - a.size * (a.size + 1) / 2.0  # U = R_a - n_a(n_a+1)/2
    centre = a.size * b.size / 2.0
    u_gap = np.abs(u_all - centre)
    u = _u_statistic(a, b)
    return Comparison(
        sizes=(a.size, b.size), means=(float(a.mean()), float(b.mean())), u=u,
        p_mann_whitney=_share_as_extreme(u_gap, abs(u - centre)),
        p_permutation=_share_as_extreme(mean_gap, abs(a.mean() - b.mean())),
        smallest_p=min(1.0, 2.0 / math.comb(pooled.size, a.size)), exact=exact)
