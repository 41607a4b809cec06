"""mjregen: grow soft voxel robots with neural cellular automata, walk them in MuJoCo,
evolve them with a genetic algorithm and regrow them after damage."""

import os

# Before torch is imported: its OpenMP threads wait for each other between the growth's
# many short operations, and by default they spin while waiting. Beside other busy
# processes (a second run on the same cores, other jobs on a cluster node) a spinning
# thread holds a core its partner needs, and a population's growth takes up to ten times
# as long (benchmarks/growth.py --load); waiting passively costs a population's growth
# at most about 0.2 s when the cores are free. A user's own setting stands.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
__all__ = ["Material", "Robot", "__version__", "plugin_library"]


def __getattr__(name: str):
    # imported when first asked for, so that importing the package (and the `mjregen`
    # command, before it has set up its process) loads neither numpy nor MuJoCo
    if name in ("Material", "Robot"):
        from mjregen import grid

        return getattr(grid, name)
    if name == "plugin_library":
        from mjregen.physics.voxel_plugin import plugin_library

        return plugin_library
    raise AttributeError(f"module 'mjregen' has no attribute {name!r}")
