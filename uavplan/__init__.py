"""uavplan: obstacle-avoiding, energy-efficient 3-D UAV mission planning (SPSA) and MAVLink."""

__version__ = "0.1.0"
