"""Experiments: the paper's conditions and scales, locomotion evolutions and regrowth runs
as library functions (the command line and the scripts call these), the walkers picked for
regrowth and the locomotion-recovery table."""
