"""`benchmarks/explicit_schemes.py`: explicit schemes on a damped network's modes, checked
against the closed forms of their stability limits and numerical damping."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjregen.physics.timestep import stable_step

from repo_modules import load_module

schemes = load_module("benchmarks/explicit_schemes.py")

LAMBDA = 1.37e8  # s⁻², a 7×7×7 soft block's
ZETA = 1.77  # its fastest mode's damping ratio
MU = 2.0 * ZETA * math.sqrt(LAMBDA)


def test_semi_implicit_eulers_limit_is_the_network_rules():
    # h²λ + 2hμ = 4 at the fastest mode; no slower mode is less stable
    limit = schemes.stability_limit(schemes.semi_implicit_euler, LAMBDA, MU)
    assert limit == pytest.approx(stable_step(LAMBDA, MU), rel=1e-6)


def test_forward_eulers_limit_is_its_fastest_real_root():
    # the fastest mode is overdamped: its fast first-order rate is ω (ζ + √(ζ² − 1)), and
    # forward Euler is stable while h times it stays within 2
    fast = math.sqrt(LAMBDA) * (ZETA + math.sqrt(ZETA ** 2 - 1.0))
    limit = schemes.stability_limit(schemes.chebyshev_scheme(1), LAMBDA, MU)
    assert limit == pytest.approx(2.0 / fast, rel=1e-6)


@pytest.mark.parametrize("stages", [1, 2, 3, 5])
def test_undamped_chebyshev_polynomials_reach_two_s_squared_on_the_real_axis(stages):
    # T_s(1 + z/s²) stays within ±1 on −2s² ≤ z ≤ 0 and leaves it beyond
    scheme = schemes.chebyshev_scheme(stages, damping=0.0)
    overdamped = np.array([1.0])  # ω = 1, c large: rates ≈ −c and −1/c
    for z, inside in [(-2.0 * stages ** 2 * 0.999, True), (-2.0 * stages ** 2 * 1.01, False)]:
        c = -z  # h = 1: the fast rate −c + 1/c ≈ z
        amplification = scheme(1.0, overdamped, np.array([c + 1.0 / c]))[0]
        assert (amplification <= 1.0) == inside


def test_slow_modes_keep_their_damping_under_semi_implicit_euler_not_forward_euler():
    """Forward Euler multiplies a mode's energy by |1 + h s|² = 1 − 2ζhω + h²ω², so it damps
    at ζ' = ζ − hω/2, and with ζ = c/2ω keeps 1 − hω²/c of the damping, the same share
    for every mode when c ∝ ω²; semi-implicit Euler multiplies it by 1 − hc."""
    h = 0.75 * stable_step(LAMBDA, MU)
    omega = 2.0 * math.pi * 40.0
    c = MU * omega ** 2 / LAMBDA
    forward = schemes.damping_kept(schemes.chebyshev_scheme(1), h, omega, LAMBDA, MU)
    assert forward == pytest.approx(1.0 - h * omega ** 2 / c, rel=1e-3)
    assert forward == pytest.approx(1.0 - h * LAMBDA / MU, rel=1e-3)
    semi = schemes.damping_kept(schemes.semi_implicit_euler, h, omega, LAMBDA, MU)
    assert semi == pytest.approx(-math.log(1.0 - h * c) / (h * c), rel=1e-6)
    assert abs(semi - 1.0) < 0.01


def test_comparison_rows_put_each_scheme_against_semi_implicit_euler():
    rows = schemes.comparison(LAMBDA, MU, 0.75, 2.0 * math.pi * 40.0)
    assert [r["scheme"] for r in rows] == ["semi-implicit Euler", "RKC 1", "RKC 2", "RKC 3"]
    assert rows[0]["limit"] == pytest.approx(1.0)
    assert rows[0]["step_keeping"] == pytest.approx(1.0 / 0.75)  # keeps it at every stable step
    for row in rows[1:]:
        assert row["limit"] > 1.0 and row["damping_kept"] < 0.97
        assert row["step_keeping"] < row["limit"] / 0.75
    with pytest.raises(ValueError, match="at least one stage"):
        schemes.chebyshev_scheme(0)
