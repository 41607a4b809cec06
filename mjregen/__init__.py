"""mjregen: grow soft voxel robots with neural cellular automata, walk them in MuJoCo,
evolve them with a genetic algorithm and regrow them after damage."""

from mjregen.grid import Material, Robot

__version__ = "0.1.0"
__all__ = ["Material", "Robot", "__version__", "plugin_library"]


def __getattr__(name: str):
    # `mjregen.plugin_library` imports MuJoCo only when asked for
    if name == "plugin_library":
        from mjregen.physics.native import plugin_library

        return plugin_library
    raise AttributeError(f"module 'mjregen' has no attribute {name!r}")
