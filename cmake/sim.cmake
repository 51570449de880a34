# Simulator: ROS-free core (marl_mrta_sim_core) + the `simulator` node.
