"""mjregen: grow soft voxel robots with neural cellular automata, walk them in MuJoCo,
evolve them with a genetic algorithm and regrow them after damage."""

from mjregen.grid import Material, Robot
from mjregen.physics.native import plugin_library

__version__ = "0.1.0"
__all__ = ["Material", "Robot", "__version__", "plugin_library"]
