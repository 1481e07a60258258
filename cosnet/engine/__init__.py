"""The net flattened and stepped: the effect registry, flatten, the Simulation, its watch, the index
checks of the kernels' tables, measures and checkpoints."""
