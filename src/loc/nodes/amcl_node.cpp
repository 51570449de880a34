// amcl drop-in (KLD-sampling particle filter, likelihood-field laser model), see amcl_ros.h.
#include "amcl_ros.h"
#include "marl_mrta/nav/node_main.h"

int main(int argc, char** argv) {
  using marl_mrta::loc::AmclRos;
  return marl_mrta::nav::runNodeShell<AmclRos>(argc, argv, "amcl",
                                               [](const AmclRos& node) { return node.failed() ? 1 : 0; });
}
