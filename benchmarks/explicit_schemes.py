"""Explicit one-step schemes on a robot's damped bond network, against semi-implicit Euler
(the plugin's stepper): how long a step each allows, and how much of the slow modes'
damping it keeps there.

The network is modelled by its modes, x'' + c x' + ω² x = 0 for 0 < ω ≤ √λ, damped in
proportion to their stiffness (C = βK): c = μ ω²/λ, with λ (s⁻²) and μ (s⁻¹) the largest
eigenvalues of M⁻¹K and M⁻¹C (`mjregen.physics.timestep.network_rates`). A scheme is its
amplification of one mode over one step; it is stable at h when no mode's amplification
exceeds 1, and a mode of damping ratio ζ = c/2ω that it amplifies by |A| per step is
damped at ζ' = −ln|A| / (h ω): ζ'/ζ is the share of the mode's damping the scheme keeps.

The explicit Runge–Kutta schemes here are the damped Chebyshev (RKC) ones, those with the
longest real stability interval for their number of force evaluations (s stages: about
2s²); one stage is forward Euler.

    python benchmarks/explicit_schemes.py LAMBDA MU
"""

from __future__ import annotations

import argparse
import math
from typing import Callable

import numpy as np
from numpy.polynomial import chebyshev

MODES = 4000  # modes sampled over 0 < ω ≤ √λ
CHEBYSHEV_DAMPING = 0.05  # RKC's usual ε: its stability region stays connected
BISECTIONS = 60

Amplification = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
"""(h s, ω ``(n,)`` rad/s, c ``(n,)`` s⁻¹) -> ``(n,)`` the larger |eigenvalue| of each mode's
one-step map."""


def network_modes(stiffness_rate: float, damping_rate: float,
                  count: int = MODES) -> tuple[np.ndarray, np.ndarray]:
    """(ω ``(count,)`` rad/s, c ``(count,)`` s⁻¹): the modelled network's modes up
    to √λ, damped c = μ ω²/λ."""
    omega = math.sqrt(stiffness_rate) * np.linspace(1.0 / count, 1.0, count)
    return omega, damping_rate * omega ** 2 / stiffness_rate


def semi_implicit_euler(h: float, omega: np.ndarray, c: np.ndarray) -> np.ndarray:
    """v' = v − h (ω² x + c v), x' = x + h v': roots of z² − (2 − hc − h²ω²) z + (1 − hc)."""
    trace = 2.0 - h * c - (h * omega) ** 2
    determinant = 1.0 - h * c
    root = np.sqrt((trace ** 2 / 4.0 - determinant).astype(complex))
    return np.maximum(np.abs(trace / 2.0 + root), np.abs(trace / 2.0 - root))


def chebyshev_scheme(stages: int, damping: float = CHEBYSHEV_DAMPING) -> Amplification:
    """First-order damped Chebyshev Runge–Kutta with `stages` force evaluations per step:
    stability polynomial P(z) = T_s(w0 + w1 z) / T_s(w0), w0 = 1 + ε/s², w1 = T_s(w0) /
    T_s'(w0), applied to the mode's first-order eigenvalues −c/2 ± √(c²/4 − ω²)."""
    if stages < 1:
        raise ValueError(f"a scheme needs at least one stage, got {stages}")
    t = chebyshev.Chebyshev([0.0] * stages + [1.0])
    w0 = 1.0 + damping / stages ** 2
    w1 = t(w0) / t.deriv()(w0)

    def amplification(h: float, omega: np.ndarray, c: np.ndarray) -> np.ndarray:
        root = np.sqrt((c ** 2 / 4.0 - omega ** 2).astype(complex))
        return np.maximum(*(np.abs(t(w0 + w1 * h * (-c / 2.0 + sign * root)) / t(w0))
                            for sign in (1.0, -1.0)))

    return amplification


def stability_limit(scheme: Amplification, stiffness_rate: float, damping_rate: float) -> float:
    """s: the longest step at which `scheme` amplifies no mode of the network (the stable
    steps are taken to be one interval from 0)."""
    omega, c = network_modes(stiffness_rate, damping_rate)

    def stable(h: float) -> bool:
        return bool(np.all(scheme(h, omega, c) <= 1.0 + 1e-12))

    high = 1.0 / math.sqrt(stiffness_rate)
    while stable(high):
        high *= 2.0
    return _longest(stable, high)


def _longest(holds: Callable[[float], bool], high: float) -> float:
    """The longest step in [0, high] up to which `holds` (true from 0 up to it, false
    beyond): `high` if it holds there, else by bisection."""
    if holds(high):
        return high
    low = 0.0
    for _ in range(BISECTIONS):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if holds(middle) else (low, middle)
    return low


def damping_kept(scheme: Amplification, h: float, omega: float, stiffness_rate: float,
                 damping_rate: float) -> float:
    """ζ'/ζ of the mode at `omega` rad/s (underdamped) stepped by `scheme` at h s."""
    c = damping_rate * omega ** 2 / stiffness_rate
    amplification = scheme(h, np.array([omega]), np.array([c]))[0]
    return -math.log(amplification) / (h * omega) / (c / (2.0 * omega))


def comparison(stiffness_rate: float, damping_rate: float, safety: float, omega: float,
               stages: tuple[int, ...] = (1, 2, 3), kept: float = 0.97) -> list[dict]:
    """Per scheme (semi-implicit Euler, then RKC with each of `stages`): its limit over
    semi-implicit Euler's, the damping it keeps at `safety` of its own limit at the mode
    `omega` rad/s, and its longest step keeping `kept` of that damping, over semi-implicit
    Euler's step at `safety` (per force evaluation: divide by the stages)."""
    rows = []
    for count, scheme in [(1, semi_implicit_euler)] + [(s, chebyshev_scheme(s)) for s in stages]:
        limit = stability_limit(scheme, stiffness_rate, damping_rate)

        def keeps(h: float, scheme: Amplification = scheme) -> bool:
            return damping_kept(scheme, h, omega, stiffness_rate, damping_rate) >= kept

        rows.append({"scheme": "semi-implicit Euler" if scheme is semi_implicit_euler
                     else f"RKC {count}", "evaluations": count, "limit": limit,
                     "damping_kept": damping_kept(scheme, safety * limit, omega,
                                                  stiffness_rate, damping_rate),
                     "step_keeping": _longest(keeps, limit)})
    euler_limit = rows[0]["limit"]
    for row in rows:
        row["limit"] /= euler_limit
        row["step_keeping"] /= safety * euler_limit
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stiffness_rate", type=float, help="λ, s⁻²")
    parser.add_argument("damping_rate", type=float, help="μ, s⁻¹")
    parser.add_argument("--safety", type=float, default=0.75)
    parser.add_argument("--hertz", type=float, default=40.0, help="the slow mode, Hz")
    args = parser.parse_args()
    for row in comparison(args.stiffness_rate, args.damping_rate, args.safety,
                          2.0 * math.pi * args.hertz):
        print(f"{row['scheme']:>20}: limit x{row['limit']:.2f}, damping kept at "
              f"{args.safety:g} of it {row['damping_kept']:.2f}, step keeping 97 % "
              f"x{row['step_keeping']:.2f} ({row['step_keeping'] / row['evaluations']:.2f} "
              "per evaluation)")


if __name__ == "__main__":
    main()
