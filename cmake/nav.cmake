# Navigation: ROS-free cores (costmap, global planner, DWA) + drop-in nodes (map_server, move_base, localisation).
