# Navigation: ROS-free cores (costmap, global planner, DWA) + drop-in nodes (map_server, move_base, localisation).
#
# marl_mrta_nav_core knows nothing of ROS: its gtests run without a roscore. The nodes in
# src/nav/nodes/ are thin shells around it, installed under the stock executable names.
add_library(${PROJECT_NAME}_nav_core
  src/nav/costmap_config.cpp
  src/nav/costmap_grid.cpp
  src/nav/dwa_planner.cpp
  src/nav/footprint.cpp
  src/nav/ground_truth_localization.cpp
  src/nav/inflation_layer.cpp
  src/nav/layered_costmap.cpp
  src/nav/local_controller.cpp
  src/nav/move_base_config.cpp
  src/nav/move_base_core.cpp
  src/nav/navfn_planner.cpp
  src/nav/obstacle_layer.cpp
  src/nav/static_layer.cpp
)
target_link_libraries(${PROJECT_NAME}_nav_core ${PROJECT_NAME}_map ${PROJECT_NAME}_params ${YAML_CPP_LIBRARIES})

# Travel paths for the embedded executor (Python ctypes, a C ABI): navfn between every pair of
# poses on move_base's global costmap, the same core navigation runs. ROS-free.
add_library(${PROJECT_NAME}_travel src/nav/travel_c_api.cpp)
target_link_libraries(${PROJECT_NAME}_travel ${PROJECT_NAME}_nav_core ${PROJECT_NAME}_map)

# ROS glue shared by the nodes (parameter tree conversion, message conversions).
add_library(${PROJECT_NAME}_nav_ros src/nav/nodes/map_server_ros.cpp src/nav/nodes/ros_conversions.cpp)
target_link_libraries(${PROJECT_NAME}_nav_ros ${PROJECT_NAME}_nav_core ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_nav_ros ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})

# Same executable names as the stock nodes, so launch files only change the package.
foreach(node map_server move_base fake_localization)
  add_executable(nav_${node} src/nav/nodes/${node}_node.cpp)
  set_target_properties(nav_${node} PROPERTIES OUTPUT_NAME ${node})
  target_link_libraries(nav_${node} ${PROJECT_NAME}_nav_ros ${PROJECT_NAME}_nav_core ${catkin_LIBRARIES})
  add_dependencies(nav_${node} ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})
  install(TARGETS nav_${node} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
endforeach()
# move_base's ROS shell, shared by the node and the nodelet (cmake/nodelets.cmake).
add_library(${PROJECT_NAME}_move_base_ros
  src/nav/nodes/move_base_inputs.cpp
  src/nav/nodes/move_base_outputs.cpp
  src/nav/nodes/move_base_ros.cpp
  src/nav/nodes/transform_source.cpp
)
target_link_libraries(${PROJECT_NAME}_move_base_ros ${PROJECT_NAME}_nav_ros ${PROJECT_NAME}_nav_core ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_move_base_ros ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})
target_link_libraries(nav_move_base ${PROJECT_NAME}_move_base_ros)
install(TARGETS ${PROJECT_NAME}_move_base_ros ${PROJECT_NAME}_nav_core ${PROJECT_NAME}_nav_ros ${PROJECT_NAME}_travel
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})

# Speed of the cores alone (scripts/bench_nav runs it).
add_executable(bench_nav_core src/nav/bench_nav_core.cpp)
target_link_libraries(bench_nav_core ${PROJECT_NAME}_nav_core ${PROJECT_NAME}_travel)
install(TARGETS bench_nav_core RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

marl_mrta_add_gtest(test_nav_core nav
  TESTS costmap navfn dwa nav_params move_base_core robot_description travel
  LIBRARIES ${PROJECT_NAME}_nav_core ${PROJECT_NAME}_travel)
