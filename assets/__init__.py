"""Data shipped with mjregen: the paper's robots, evolved NCAs, walkers, regrowth NCAs (package `mjregen.assets` once installed; read with `mjregen.resources.asset`)."""
