# Localisation: the particle filter's ROS-free core (marl_mrta_loc_core: filter, odometry and
# laser models, the map's distance field) + the `amcl` drop-in node around it.
#
# marl_mrta_loc_core knows nothing of ROS: its gtests run without a roscore. nav_core lends it
# the transform helpers (ground_truth_localization.h), params the parameter tree.
add_library(${PROJECT_NAME}_loc_core
  src/loc/amcl_config.cpp
  src/loc/laser_model.cpp
  src/loc/localization_map.cpp
  src/loc/localizer.cpp
  src/loc/odometry_model.cpp
  src/loc/particle_filter.cpp
  src/loc/pose_histogram.cpp
  src/loc/random_source.cpp
)
target_link_libraries(${PROJECT_NAME}_loc_core ${PROJECT_NAME}_nav_core ${PROJECT_NAME}_params ${PROJECT_NAME}_map
  ${YAML_CPP_LIBRARIES})

# Same executable name as the stock node, so launch files only change the package.
add_executable(loc_amcl src/loc/nodes/amcl_node.cpp src/loc/nodes/amcl_ros.cpp src/loc/nodes/amcl_scans.cpp)
set_target_properties(loc_amcl PROPERTIES OUTPUT_NAME amcl)
target_link_libraries(loc_amcl ${PROJECT_NAME}_loc_core ${PROJECT_NAME}_nav_ros ${catkin_LIBRARIES})
add_dependencies(loc_amcl ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})

# Speed of the core alone: CPU time per filter update on the lab (scans cast by the simulator core).
add_executable(bench_loc_core src/loc/bench_loc_core.cpp)
target_link_libraries(bench_loc_core ${PROJECT_NAME}_loc_core ${PROJECT_NAME}_sim_core)

install(TARGETS bench_loc_core loc_amcl ${PROJECT_NAME}_loc_core
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION}
)

# The simulator core casts the scans and drives the robot: linked into the tests only.
marl_mrta_add_gtest(test_loc_core loc
  TESTS amcl_config laser_model localization odometry_model particle_filter
  LIBRARIES ${PROJECT_NAME}_loc_core ${PROJECT_NAME}_sim_core)
