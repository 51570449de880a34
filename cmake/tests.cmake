# pytest (ROS-free Python cores) and rostest (the ROS graph). gtests are declared beside
# the core they test (cmake/<subsystem>.cmake). All results land in catkin's test results
# directory so that `catkin_test_results` sees every failure.
find_package(rostest REQUIRED)

# Three pytest processes (pytest-xdist; an idle one takes tests queued for the others) on two
# cores: the differential navigation test drives for minutes in wall time with little CPU
# (test/python/conftest.py queues it first), while the other two keep both cores busy.
catkin_run_tests_target("pytest" "python" "pytest-python.xml"
  COMMAND "${PYTHON_EXECUTABLE} -m pytest -q -p no:cacheprovider -n 3 --dist worksteal ${PROJECT_SOURCE_DIR}/test/python --junitxml=${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/pytest-python.xml"
  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})

file(GLOB MARL_MRTA_ROSTESTS RELATIVE ${PROJECT_SOURCE_DIR} test/rostest/*.test)
foreach(launch_file ${MARL_MRTA_ROSTESTS})
  add_rostest(${launch_file})
endforeach()
