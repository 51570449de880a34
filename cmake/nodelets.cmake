# The simulator, the built-in map_server and move_base as nodelets (nodelet_plugins.xml), for running them
# in one process: sim.launch nodelets:=true. The same ROS shells as the nodes.
add_library(${PROJECT_NAME}_nodelets
  src/nav/nodes/map_server_nodelet.cpp
  src/nav/nodes/move_base_nodelet.cpp
  src/sim/simulator_nodelet.cpp
)
target_link_libraries(${PROJECT_NAME}_nodelets ${PROJECT_NAME}_sim_ros ${PROJECT_NAME}_move_base_ros ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_nodelets ${PROJECT_NAME}_generate_messages_cpp ${catkin_EXPORTED_TARGETS})
install(TARGETS ${PROJECT_NAME}_nodelets
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
install(FILES nodelet_plugins.xml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
