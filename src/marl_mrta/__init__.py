"""marl_mrta: multi-robot task allocation with MAPPO on TurtleBot3 Burgers (ROS 1 Noetic)."""
