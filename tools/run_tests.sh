#!/usr/bin/env bash
# Runs the package's tests in a built catkin workspace (sourced), in one of two tiers:
#   tools/run_tests.sh all BUILD_DIR    every test, in three streams side by side:
#       two wall-clock streams: the rostests whose file says `tier: wallclock`, and the Python
#         tests marked wallclock; they drive robots in real time with little CPU, at normal priority
#       the CPU stream, at lower priority (nice): the gtests, the other Python tests, the other
#         rostests, one after another
#   tools/run_tests.sh fast BUILD_DIR   the gtests and the Python tests marked neither ros,
#       wallclock nor slow (the ROS-free unit tier)
# Results land in BUILD_DIR/test_results/marl_mrta (JUnit), read by tools/test_summary.py.
set -uo pipefail
tier=${1:?usage: run_tests.sh all|fast BUILD_DIR}
build=${2:?usage: run_tests.sh all|fast BUILD_DIR}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
results=$build/test_results/marl_mrta
mkdir -p "$results"

gtest_targets=$(make -C "$build" help | sed -n 's/^\.\.\. \(_run_tests_marl_mrta_gtest_.*\)$/\1/p')

run_targets() {  # each catkin test target in turn, going on past a failed one (its result file says so)
  # Through the target's own rule: catkin's `make TARGET` first cleans the whole results
  # directory (clean_test_results), which would lose the other stream's results.
  local status=0 target
  for target in "$@"; do
    make --no-print-directory -s -C "$build" -f "marl_mrta/CMakeFiles/$target.dir/build.make" \
      "marl_mrta/CMakeFiles/$target.dir/build" || status=1
  done
  return $status
}

case "$tier" in
  fast)
    run_targets $gtest_targets
    gtest_status=$?
    (cd "$here" && python3 -m pytest -q -p no:cacheprovider -m "not ros and not wallclock and not slow" -n 2 \
       --dist worksteal test/python --junitxml="$results/pytest-fast.xml")
    pytest_status=$?
    [ $gtest_status -eq 0 ] && [ $pytest_status -eq 0 ]
    ;;
  all)
    wall_ros=()
    cpu=($gtest_targets _run_tests_marl_mrta_pytest_python)
    for test_file in "$here"/test/rostest/*.test; do
      target=_run_tests_marl_mrta_rostest_test_rostest_$(basename "$test_file")
      if grep -q "tier: wallclock" "$test_file"; then wall_ros+=("$target"); else cpu+=("$target"); fi
    done
    # The wall-clock tests wait on real time with little CPU: the Python ones and the rostests in
    # two streams of their own, beside the CPU-bound ones.
    run_targets _run_tests_marl_mrta_pytest_wallclock >"$results/../wallclock_python.log" 2>&1 &
    wall_python=$!
    run_targets "${wall_ros[@]}" >"$results/../wallclock_rostest.log" 2>&1 &
    wall_rostest=$!
    nice -n 10 bash -c "$(declare -f run_targets); build=$build; run_targets ${cpu[*]}"
    cpu_status=$?
    wait $wall_python; python_status=$?
    wait $wall_rostest; rostest_status=$?
    for log in wallclock_python wallclock_rostest; do
      echo "== the $log stream's output (all of it in $results/../$log.log)"
      tail -n 20 "$results/../$log.log"
    done
    [ $cpu_status -eq 0 ] && [ $python_status -eq 0 ] && [ $rostest_status -eq 0 ]
    ;;
  *)
    echo "run_tests.sh: unknown tier '$tier' (all | fast)" >&2
    exit 2
    ;;
esac
