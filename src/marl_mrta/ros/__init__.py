"""ROS shells around the ROS-free cores: executors, node classes and message conversions."""
