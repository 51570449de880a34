# Occupancy maps in map_server YAML + PGM or PNG format (shared by the simulator and navigation).
add_library(${PROJECT_NAME}_map
  src/map/occupancy_map.cpp
  src/map/pgm.cpp
  src/map/png.cpp
)
target_link_libraries(${PROJECT_NAME}_map ${YAML_CPP_LIBRARIES} ${PNG_LIBRARIES})
install(TARGETS ${PROJECT_NAME}_map
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
)

marl_mrta_add_gtest(test_map_loading map TESTS occupancy_map map_server_maps LIBRARIES ${PROJECT_NAME}_map)
