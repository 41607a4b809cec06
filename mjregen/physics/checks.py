"""Validation of physical parameters: each failure a `PhysicsParameterError` naming the
parameter, its value and what it may be."""

from __future__ import annotations

import math

from mjregen.errors import PhysicsParameterError


def check_range(name: str, value: float, *, low: float, high: float = math.inf,
           low_open: bool = True, high_open: bool = False) -> None:
    """Raise PhysicsParameterError unless `value` is a finite real number in the range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PhysicsParameterError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise PhysicsParameterError(f"{name} must be finite, got {value!r}")
    too_low = value <= low if low_open else value < low
    too_high = value >= high if high_open else value > high
    if too_low or too_high:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        raise PhysicsParameterError(
            f"{name} = {value!r} is outside its valid range {left}{low}, {high}{right}"
        )


def check_choice(name: str, value: object, allowed: tuple, *, hint: str = "") -> None:
    if value not in allowed:
        raise PhysicsParameterError(f"{name} must be one of {allowed}, got {value!r}{hint}")


def check_flag(name: str, value: object) -> None:
    if not isinstance(value, bool):
        raise PhysicsParameterError(f"{name} must be True or False, got {value!r}")
