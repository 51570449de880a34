// A histogram of poses over (x, y, yaw) bins, kept in a kd-tree as amcl's pf_kdtree: the bins
// that hold samples are its leaves, so memory follows the samples, not the map. KLD-sampling
// counts its leaves; clustering joins bins that touch (the 26 neighbours of a bin).
//
// Bins are 0.5 m x 0.5 m x 10 degrees, as amcl's. Unlike amcl's, yaw is taken in [-pi, pi) and the
// bins on either side of +-pi are neighbours, so a cloud around yaw = pi is one cluster, not two.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace loc {

using nav::Pose2D;

class PoseHistogram {
 public:
  static constexpr double kBinSize = 0.5;  // [m] along x and y
  static constexpr int kYawBins = 36;      // 10 degrees each
  using Key = std::array<int, 3>;          // bin indices along x, y, yaw

  static Key keyOf(const Pose2D& pose);

  void clear();
  void insert(const Pose2D& pose, double weight);
  // Bins holding at least one sample.
  size_t binCount() const { return leaf_count_; }
  // Summed weight of the bin holding `pose` (0 when empty).
  double weightAt(const Pose2D& pose) const;

  // Labels every bin with its cluster (connected bins); returns the number of clusters.
  int cluster();
  // The cluster of the bin holding `pose` after cluster(), -1 for an empty bin.
  int clusterOf(const Pose2D& pose) const;

 private:
  struct Node {
    Key key{};
    double weight = 0.0;
    bool leaf = true;
    int pivot_dim = 0;         // split dimension of an inner node
    double pivot_value = 0.0;  // keys below it go to children[0]
    int children[2] = {-1, -1};
    int cluster = -1;
  };
  int newLeaf(const Key& key, double weight);
  int findLeaf(const Key& key) const;

  std::vector<Node> nodes_;
  int root_ = -1;
  size_t leaf_count_ = 0;
  std::vector<int> stack_;  // scratch of cluster()
};

}  // namespace loc
}  // namespace marl_mrta
