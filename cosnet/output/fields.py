"""What the output's tables hold: the energy budget's columns and the unit of every field a
frame or a probe records (read by the writer, the reader, the pictures and the plots)."""

from ..engine.registry import ACCOUNTS

# the energy budget at every frame (J): energy() = kinetic + strain + potential, and the
# accounts that balance it (ACCOUNTS: energy - driver - actuation - loads - supplied +
# dissipated is constant but for the scheme's error)
ENERGY_COLUMNS = ("kinetic", "strain", "potential", *ACCOUNTS)
# the unit of each field a frame or a probe holds ("": none)
FIELD_UNITS = {"position": "m", "displacement": "m", "velocity": "m/s", "angular_velocity": "rad/s",
               "force": "N", "torque": "N m", "reaction": "N", "reaction_torque": "N m", "strain": "",
               "curvature": "1/m", "d1": "", "d2": "", "d3": "", "joint_angle": "rad", "joint_rate": "rad/s",
               "joint_reaction": "N m"}
