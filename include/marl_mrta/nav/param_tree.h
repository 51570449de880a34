// Typed, checked reading of a parameter tree (a node's private namespace as rosparam holds it),
// with a record of which keys were read so that unknown keys can be reported.
//
// The tree is a YAML::Node: tests build it from the YAML files as `rosparam load` would; the
// node converts its private parameter namespace into one. Every error is one line naming the
// parameter ("move_base/local_costmap/width: expected a number, got 'wide'").
#pragma once

#include <yaml-cpp/yaml.h>

#include <limits>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "marl_mrta/nav/param_error.h"

namespace marl_mrta {
namespace nav {

class ParamNode {
 public:
  // `path` names the tree in messages, e.g. "move_base".
  ParamNode(const YAML::Node& tree, const std::string& path);
  ParamNode(const ParamNode&) = default;
  // Assigning would rebind the shared YAML data (yaml-cpp semantics).
  ParamNode& operator=(const ParamNode&) = delete;

  const std::string& path() const { return path_; }
  std::string pathOf(const std::string& key) const { return path_ + "/" + key; }
  bool has(const std::string& key) const;

  // Typed getters: the default when the key is absent, ParamError when present but of the
  // wrong type or outside [min, max]. Reading marks the key as read.
  double getDouble(const std::string& key, double default_value,
                   double min = -std::numeric_limits<double>::infinity(),
                   double max = std::numeric_limits<double>::infinity()) const;
  int getInt(const std::string& key, int default_value, int min = std::numeric_limits<int>::min(),
             int max = std::numeric_limits<int>::max()) const;
  bool getBool(const std::string& key, bool default_value) const;
  std::string getString(const std::string& key, const std::string& default_value) const;
  // The first of `keys` that is present (e.g. new name, then old name); marks all present as read.
  // Returns the key used, or "" when none is present.
  std::string firstPresent(const std::vector<std::string>& keys) const;

  // A sub-namespace (an empty one when absent). ParamError when the key holds a non-map.
  ParamNode child(const std::string& key) const;
  // The raw value (whole subtree marked as read). Undefined node when absent.
  YAML::Node raw(const std::string& key) const;
  // Marks a key as read without interpreting it (parameters accepted for compatibility).
  void accept(const std::string& key) const;
  std::vector<std::string> keys() const;

  // Keys present in the whole tree that no getter read, as full paths, sorted.
  std::vector<std::string> unreadKeys() const;

 private:
  struct Record {
    std::set<std::string> read_whole;  // leaves and subtrees read as one value
    std::set<std::string> opened;      // namespaces entered with child()
  };
  ParamNode(const YAML::Node& node, const std::string& path, std::shared_ptr<Record> record, YAML::Node root,
            std::string root_path);
  YAML::Node lookup(const std::string& key) const;
  void markRead(const std::string& key) const;
  void collectUnread(const YAML::Node& node, const std::string& path, std::vector<std::string>& out) const;

  YAML::Node node_;
  std::string path_;
  std::shared_ptr<Record> record_;
  YAML::Node root_;
  std::string root_path_;
};

// Loads a YAML file into `tree` under the namespace `ns` ("" = top), merging maps like
// `rosparam load file ns`. Throws ParamError naming the file on a syntax error.
void loadYamlFileInto(YAML::Node& tree, const std::string& file, const std::string& ns);
// Sets `tree[a][b]...` for a slash-separated key ("DWAPlannerROS/min_vel_x").
void setParam(YAML::Node& tree, const std::string& key, const YAML::Node& value);

}  // namespace nav
}  // namespace marl_mrta
