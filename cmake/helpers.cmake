# Declarations shared by the subsystem files (cmake/<subsystem>.cmake); included before them.

if(CATKIN_ENABLE_TESTING)
  # catkin links gtest but, depending on the platform, not gtest's main().
  if(TARGET GTest::gtest_main)
    set(MARL_MRTA_GTEST_MAIN GTest::gtest_main)
  elseif(TARGET gtest_main)
    set(MARL_MRTA_GTEST_MAIN gtest_main)
  endif()
endif()

# A core's gtests, run from the source tree:
#   marl_mrta_add_gtest(<target> <subsystem> TESTS <name>... LIBRARIES <library>...)
# builds test/gtest/<subsystem>/test_<name>.cpp (in that order) into <target>. Nothing without
# CATKIN_ENABLE_TESTING. Maps, parameter files and fixtures are found from MARL_MRTA_SOURCE_DIR
# (the build may live anywhere).
function(marl_mrta_add_gtest target subsystem)
  if(NOT CATKIN_ENABLE_TESTING)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "TESTS;LIBRARIES" ${ARGN})
  set(sources)
  foreach(name ${ARG_TESTS})
    list(APPEND sources test/gtest/${subsystem}/test_${name}.cpp)
  endforeach()
  catkin_add_gtest(${target} ${sources} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  if(TARGET ${target})
    target_compile_definitions(${target} PRIVATE MARL_MRTA_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    target_link_libraries(${target} ${ARG_LIBRARIES} ${MARL_MRTA_GTEST_MAIN})
  endif()
endfunction()
