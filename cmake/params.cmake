# The parameter tree: typed, checked reading of a node's private namespace (nav::ParamNode) and
# the one error of a bad parameter (nav::ParamError), shared by the simulator's and navigation's
# cores. ROS-free: the nodes convert their parameters into a YAML tree, tests load the files.
add_library(${PROJECT_NAME}_params src/nav/param_tree.cpp)
target_link_libraries(${PROJECT_NAME}_params ${YAML_CPP_LIBRARIES})
install(TARGETS ${PROJECT_NAME}_params
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
)
