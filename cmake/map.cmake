# Occupancy maps in map_server YAML + PGM format (shared by the simulator and navigation).
add_library(${PROJECT_NAME}_map
  src/map/occupancy_map.cpp
  src/map/pgm.cpp
)
target_link_libraries(${PROJECT_NAME}_map ${YAML_CPP_LIBRARIES})
install(TARGETS ${PROJECT_NAME}_map
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
)

if(CATKIN_ENABLE_TESTING)
  # catkin links gtest but, depending on the platform, not gtest's main().
  if(TARGET GTest::gtest_main)
    set(MARL_MRTA_GTEST_MAIN GTest::gtest_main)
  elseif(TARGET gtest_main)
    set(MARL_MRTA_GTEST_MAIN gtest_main)
  endif()

  catkin_add_gtest(test_map_loading
    test/gtest/map/test_occupancy_map.cpp
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  if(TARGET test_map_loading)
    # Fixtures are found from the source tree (the build may live anywhere).
    target_compile_definitions(test_map_loading PRIVATE MARL_MRTA_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    target_link_libraries(test_map_loading ${PROJECT_NAME}_map ${MARL_MRTA_GTEST_MAIN})
  endif()
endif()
