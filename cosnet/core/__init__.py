"""The net as declared: materials, sections, nodes and lines, the joints and sliders its line ends
carry, rotations, units and value checks, scaling (§5) and rigid contraction (§7)."""
