# pytest (ROS-free Python cores) and rostest (the ROS graph). gtests are declared beside
# the core they test (cmake/<subsystem>.cmake). All results land in catkin's test results
# directory so that `catkin_test_results` sees every failure.
find_package(rostest REQUIRED)

# The Python tests in two targets: the wall-clock ones (marker `wallclock`: robots driven in real
# time, little CPU) and the rest in two processes (pytest-xdist). `make test` runs the two beside
# each other (tools/run_tests.sh); `catkin_make run_tests` runs every target one after another.
catkin_run_tests_target("pytest" "python" "pytest-python.xml"
  COMMAND "${PYTHON_EXECUTABLE} -m pytest -q -p no:cacheprovider -m 'not wallclock' -n 2 --dist worksteal ${PROJECT_SOURCE_DIR}/test/python --junitxml=${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/pytest-python.xml"
  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
catkin_run_tests_target("pytest" "wallclock" "pytest-wallclock.xml"
  COMMAND "${PYTHON_EXECUTABLE} -m pytest -q -p no:cacheprovider -m wallclock ${PROJECT_SOURCE_DIR}/test/python --junitxml=${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/pytest-wallclock.xml"
  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})

file(GLOB MARL_MRTA_ROSTESTS RELATIVE ${PROJECT_SOURCE_DIR} test/rostest/*.test)
foreach(launch_file ${MARL_MRTA_ROSTESTS})
  add_rostest(${launch_file})
endforeach()
