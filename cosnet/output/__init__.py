"""What a run writes: frames, probes, the energy budget, checkpoints on the output schedule, VTK
files; pictures and plots of it."""
