# Simulator: ROS-free core (marl_mrta_sim_core) + the `simulator` node (docs/reference/nodes_sim_nav.md).
add_library(${PROJECT_NAME}_sim_core
  src/sim/diff_drive.cpp
  src/sim/lidar.cpp
  src/sim/lockstep_gate.cpp
  src/sim/obstacle_grid.cpp
  src/sim/robot_model.cpp
  src/sim/scan_caster.cpp
  src/sim/sim_config.cpp
  src/sim/stand_in_config.cpp
  src/sim/world.cpp
)
# params: the parameter tree the simulator's configuration is read from (cmake/params.cmake).
target_link_libraries(${PROJECT_NAME}_sim_core ${PROJECT_NAME}_map ${PROJECT_NAME}_params ${YAML_CPP_LIBRARIES})

# The ROS shell around the core, shared by the node and the nodelet (cmake/nodelets.cmake).
add_library(${PROJECT_NAME}_sim_ros
  src/sim/sim_messages_ros.cpp
  src/sim/sim_params_ros.cpp
  src/sim/simulator_ros.cpp
  src/sim/simulator_services_ros.cpp
  src/sim/stand_in_ros.cpp
)
add_dependencies(${PROJECT_NAME}_sim_ros ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})
# nav_ros: the ground-truth localisation it shares with fake_localization (publish_localization).
target_link_libraries(${PROJECT_NAME}_sim_ros ${PROJECT_NAME}_sim_core ${PROJECT_NAME}_nav_ros ${catkin_LIBRARIES})

add_executable(simulator src/sim/simulator_node.cpp)
target_link_libraries(simulator ${PROJECT_NAME}_sim_ros ${catkin_LIBRARIES})

# Benchmark helpers (scripts/bench_sim): the core alone, and a subscriber to every topic.
add_executable(bench_sim_core src/sim/bench_sim_core.cpp)
target_link_libraries(bench_sim_core ${PROJECT_NAME}_sim_core)
add_executable(bench_sim_sink src/sim/bench_sim_sink.cpp)
add_dependencies(bench_sim_sink ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})
target_link_libraries(bench_sim_sink ${catkin_LIBRARIES})

install(TARGETS bench_sim_core bench_sim_sink ${PROJECT_NAME}_sim_core ${PROJECT_NAME}_sim_ros simulator
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION}
)

# Core only: no roscore, no ROS libraries.
marl_mrta_add_gtest(test_sim_core sim
  TESTS arenas collisions drive lidar lockstep_gate sim_config
  LIBRARIES ${PROJECT_NAME}_sim_core)
