"""Markers of the Python tests' tiers (docs/guide/development.md, "Tests"):

- ros: starts ROS processes (roslaunch, nodes) or drives robots in the simulator;
- wallclock: runs on the wall clock (real time), so it shares the machine with few CPU-bound tests;
- slow: takes seconds of CPU (training, search, whole evaluations).

`make test-fast` runs the tests with none of them; `make test` runs all (cmake/tests.cmake)."""


def pytest_configure(config):
    config.addinivalue_line("markers", "ros: starts ROS processes or drives robots in the simulator")
    config.addinivalue_line("markers", "wallclock: runs on the wall clock; kept apart from CPU-bound tests")
    config.addinivalue_line("markers", "slow: takes seconds of CPU (training, search, whole evaluations)")
