"""nao_arena: a physics-simulated multi-robot testbed built around the
Nonlinear Acceleration Obstacle (NAO).

Units everywhere: metres, seconds, m/s, m/s^2; angles in radians.
"""

__version__ = "0.1.0"
