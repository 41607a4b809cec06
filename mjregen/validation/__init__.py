"""Checks of mjregen's physics against the world outside it: the paper's engine
(`engine`), the small cases and paper robots recorded from it (`reference`), walks with
another integrator, step or initial state (`integration`) and whether a robot's walk
transfers (`transfer`). benchmarks/ holds their command lines and reports."""
