"""
Pure-numpy core of formation_control (imports nothing from ROS).

Positions are complex numbers r = x + i y in the world frame (REP-103: x east/forward,
y north/left, angles counter-clockwise). The inner product is ``<a, b> = Re(conj(a) b)``.
"""
