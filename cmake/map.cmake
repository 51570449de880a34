# Occupancy maps in map_server YAML + PGM format (shared by the simulator and navigation).
