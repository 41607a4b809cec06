"""Growth: the paper's neural cellular automata (torch) that grow robot grids, their genomes
and checkpoints. Imports only the grid layer."""
