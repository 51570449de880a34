// move_base drop-in (navfn global planner + DWA local planner), see move_base_ros.h.
#include "marl_mrta/nav/node_main.h"
#include "move_base_ros.h"

int main(int argc, char** argv) {
  return marl_mrta::nav::runNodeShell<marl_mrta::nav::MoveBaseRos>(argc, argv, "move_base");
}
