"""Tasks: what a grown robot is scored on. Locomotion (fitness = distance walked − voxel
cost, each robot simulated by the physics layer) and regrowth (cells equal to an original).
A task evaluates a population on whatever evaluation backend the search layer hands it."""
