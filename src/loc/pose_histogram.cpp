#include "marl_mrta/loc/pose_histogram.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "marl_mrta/nav/local_controller.h"

namespace marl_mrta {
namespace loc {

PoseHistogram::Key PoseHistogram::keyOf(const Pose2D& pose) {
  // Yaw from [-pi, pi) to bins 0..kYawBins-1; the clamp catches rounding at the top end.
  const double turn = (nav::normalizeAngle(pose.yaw) + M_PI) / (2.0 * M_PI);
  const int yaw_bin = std::min(kYawBins - 1, std::max(0, static_cast<int>(std::floor(turn * kYawBins))));
  return {static_cast<int>(std::floor(pose.x / kBinSize)), static_cast<int>(std::floor(pose.y / kBinSize)), yaw_bin};
}

void PoseHistogram::clear() {
  nodes_.clear();
  root_ = -1;
  leaf_count_ = 0;
}

int PoseHistogram::newLeaf(const Key& key, double weight) {
  Node node;
  node.key = key;
  node.weight = weight;
  nodes_.push_back(node);
  ++leaf_count_;
  return static_cast<int>(nodes_.size()) - 1;
}

void PoseHistogram::insert(const Pose2D& pose, double weight) {
  const Key key = keyOf(pose);
  if (root_ < 0) {
    root_ = newLeaf(key, weight);
    return;
  }
  int index = root_;
  while (!nodes_[index].leaf) {
    const Node& node = nodes_[index];
    index = node.children[key[node.pivot_dim] < node.pivot_value ? 0 : 1];
  }
  if (nodes_[index].key == key) {
    nodes_[index].weight += weight;
    return;
  }
  // Split the leaf along the dimension where the two keys differ most, half-way between them.
  const Key old_key = nodes_[index].key;
  const double old_weight = nodes_[index].weight;
  int pivot_dim = 0;
  for (int d = 1; d < 3; ++d) {
    if (std::abs(key[d] - old_key[d]) > std::abs(key[pivot_dim] - old_key[pivot_dim])) pivot_dim = d;
  }
  const double pivot_value = (key[pivot_dim] + old_key[pivot_dim]) / 2.0;
  const bool new_goes_low = key[pivot_dim] < pivot_value;
  const int low = newLeaf(new_goes_low ? key : old_key, new_goes_low ? weight : old_weight);
  const int high = newLeaf(new_goes_low ? old_key : key, new_goes_low ? old_weight : weight);
  Node& split = nodes_[index];  // after the push_backs: they may have moved the nodes
  split.leaf = false;
  split.pivot_dim = pivot_dim;
  split.pivot_value = pivot_value;
  split.children[0] = low;
  split.children[1] = high;
  --leaf_count_;
}

int PoseHistogram::findLeaf(const Key& key) const {
  if (root_ < 0) return -1;
  int index = root_;
  while (!nodes_[index].leaf) {
    const Node& node = nodes_[index];
    index = node.children[key[node.pivot_dim] < node.pivot_value ? 0 : 1];
  }
  return nodes_[index].key == key ? index : -1;
}

double PoseHistogram::weightAt(const Pose2D& pose) const {
  const int leaf = findLeaf(keyOf(pose));
  return leaf < 0 ? 0.0 : nodes_[leaf].weight;
}

int PoseHistogram::cluster() {
  for (Node& node : nodes_) node.cluster = -1;
  int clusters = 0;
  for (size_t start = 0; start < nodes_.size(); ++start) {
    if (!nodes_[start].leaf || nodes_[start].cluster >= 0) continue;
    nodes_[start].cluster = clusters;
    stack_.assign(1, static_cast<int>(start));
    while (!stack_.empty()) {
      const Key key = nodes_[stack_.back()].key;
      stack_.pop_back();
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dyaw = -1; dyaw <= 1; ++dyaw) {
            const Key next = {key[0] + dx, key[1] + dy, (key[2] + dyaw + kYawBins) % kYawBins};
            const int leaf = findLeaf(next);
            if (leaf < 0 || nodes_[leaf].cluster >= 0) continue;
            nodes_[leaf].cluster = clusters;
            stack_.push_back(leaf);
          }
        }
      }
    }
    ++clusters;
  }
  return clusters;
}

int PoseHistogram::clusterOf(const Pose2D& pose) const {
  const int leaf = findLeaf(keyOf(pose));
  return leaf < 0 ? -1 : nodes_[leaf].cluster;
}

}  // namespace loc
}  // namespace marl_mrta
