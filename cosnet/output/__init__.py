"""What a run writes: frames, probes, checkpoints on the output schedule, VTK files, pictures."""
