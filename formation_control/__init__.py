"""Formation control of vehicle fleets after Mellish (2011): particles and planar rigid bodies."""
