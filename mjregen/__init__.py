"""mjregen: grow soft voxel robots with neural cellular automata, walk them in MuJoCo,
evolve them with a genetic algorithm and regrow them after damage."""

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
