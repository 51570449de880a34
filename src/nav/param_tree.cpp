#include "marl_mrta/nav/param_tree.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace nav {
namespace {

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a namespace";
  return "nothing";
}

// Deep merge of src into dst: maps merge key by key, anything else replaces.
void mergeNode(YAML::Node dst, const YAML::Node& src) {
  for (const auto& entry : src) {
    const std::string key = entry.first.as<std::string>();
    if (entry.second.IsMap() && dst[key].IsMap()) {
      mergeNode(dst[key], entry.second);
    } else {
      dst[key] = YAML::Clone(entry.second);
    }
  }
}

std::vector<std::string> splitNamespace(const std::string& ns) {
  std::vector<std::string> parts;
  std::stringstream stream(ns);
  std::string part;
  while (std::getline(stream, part, '/')) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

}  // namespace

ParamNode::ParamNode(const YAML::Node& tree, const std::string& path)
    : node_(tree), path_(path), record_(std::make_shared<Record>()), root_(tree), root_path_(path) {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) {
    throw ParamError(path, "expected a namespace of parameters, got " + describe(node_));
  }
}

ParamNode::ParamNode(const YAML::Node& node, const std::string& path, std::shared_ptr<Record> record,
                     YAML::Node root, std::string root_path)
    : node_(node), path_(path), record_(std::move(record)), root_(root), root_path_(std::move(root_path)) {}

YAML::Node ParamNode::lookup(const std::string& key) const {
  if (!node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  for (const auto& entry : node_) {
    if (entry.first.as<std::string>() == key) return entry.second;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

bool ParamNode::has(const std::string& key) const { return lookup(key).IsDefined(); }

void ParamNode::markRead(const std::string& key) const { record_->read_whole.insert(pathOf(key)); }

void ParamNode::accept(const std::string& key) const {
  if (has(key)) markRead(key);
}

double ParamNode::getDouble(const std::string& key, double default_value, double min, double max) const {
  const YAML::Node value = lookup(key);
  if (!value.IsDefined()) return default_value;
  markRead(key);
  double result = 0.0;
  if (!value.IsScalar() || !YAML::convert<double>::decode(value, result) || std::isnan(result)) {
    throw ParamError(pathOf(key), "expected a number, got " + describe(value));
  }
  if (result < min || result > max) {
    std::ostringstream range;
    range << "must be in [" << min << ", " << max << "], got " << result;
    throw ParamError(pathOf(key), range.str());
  }
  return result;
}

int ParamNode::getInt(const std::string& key, int default_value, int min, int max) const {
  const YAML::Node value = lookup(key);
  if (!value.IsDefined()) return default_value;
  markRead(key);
  double result = 0.0;
  if (!value.IsScalar() || !YAML::convert<double>::decode(value, result) || result != std::floor(result)) {
    throw ParamError(pathOf(key), "expected an integer, got " + describe(value));
  }
  if (result < min || result > max) {
    throw ParamError(pathOf(key), "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " +
                                      std::to_string(static_cast<long long>(result)));
  }
  return static_cast<int>(result);
}

bool ParamNode::getBool(const std::string& key, bool default_value) const {
  const YAML::Node value = lookup(key);
  if (!value.IsDefined()) return default_value;
  markRead(key);
  bool result = false;
  if (!value.IsScalar() || !YAML::convert<bool>::decode(value, result)) {
    throw ParamError(pathOf(key), "expected true or false, got " + describe(value));
  }
  return result;
}

std::string ParamNode::getString(const std::string& key, const std::string& default_value) const {
  const YAML::Node value = lookup(key);
  if (!value.IsDefined()) return default_value;
  markRead(key);
  if (!value.IsScalar()) throw ParamError(pathOf(key), "expected a string, got " + describe(value));
  return value.Scalar();
}

std::string ParamNode::firstPresent(const std::vector<std::string>& keys) const {
  std::string found;
  for (const std::string& key : keys) {
    if (has(key) && found.empty()) found = key;
  }
  return found;
}

ParamNode ParamNode::child(const std::string& key) const {
  const YAML::Node value = lookup(key);
  if (!value.IsDefined()) {
    return ParamNode(YAML::Node(YAML::NodeType::Map), pathOf(key), record_, root_, root_path_);
  }
  if (!value.IsMap()) throw ParamError(pathOf(key), "expected a namespace of parameters, got " + describe(value));
  record_->opened.insert(pathOf(key));
  return ParamNode(value, pathOf(key), record_, root_, root_path_);
}

YAML::Node ParamNode::raw(const std::string& key) const {
  const YAML::Node value = lookup(key);
  if (value.IsDefined()) markRead(key);
  return value;
}

std::vector<std::string> ParamNode::keys() const {
  std::vector<std::string> result;
  if (!node_.IsMap()) return result;
  for (const auto& entry : node_) result.push_back(entry.first.as<std::string>());
  return result;
}

void ParamNode::collectUnread(const YAML::Node& node, const std::string& path, std::vector<std::string>& out) const {
  if (!node.IsMap()) return;
  for (const auto& entry : node) {
    const std::string key_path = path + "/" + entry.first.as<std::string>();
    if (record_->read_whole.count(key_path)) continue;
    if (record_->opened.count(key_path)) {
      collectUnread(entry.second, key_path, out);
    } else {
      out.push_back(key_path);
    }
  }
}

std::vector<std::string> ParamNode::unreadKeys() const {
  std::vector<std::string> out;
  collectUnread(root_, root_path_, out);
  std::sort(out.begin(), out.end());
  return out;
}

// yaml-cpp's Node::operator= rebinds shared data, so the walks below recurse with fresh
// Node values instead of reassigning a cursor.
void setAt(YAML::Node node, const std::vector<std::string>& parts, size_t i, const YAML::Node& value) {
  if (i + 1 == parts.size()) {
    node[parts[i]] = YAML::Clone(value);
    return;
  }
  if (!node[parts[i]].IsMap()) node[parts[i]] = YAML::Node(YAML::NodeType::Map);
  setAt(node[parts[i]], parts, i + 1, value);
}

void setParam(YAML::Node& tree, const std::string& key, const YAML::Node& value) {
  const std::vector<std::string> parts = splitNamespace(key);
  if (parts.empty()) return;
  if (!tree.IsMap()) tree = YAML::Node(YAML::NodeType::Map);
  setAt(tree, parts, 0, value);
}

void loadYamlFileInto(YAML::Node& tree, const std::string& file, const std::string& ns) {
  YAML::Node content;
  try {
    content = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw ParamError(file, "cannot be read");
  } catch (const YAML::Exception& error) {
    throw ParamError(file, "line " + std::to_string(error.mark.line + 1) + ": " + error.msg);
  }
  if (content.IsNull()) return;
  if (!content.IsMap()) throw ParamError(file, "expected a mapping of parameters at the top level");
  if (!tree.IsMap()) tree = YAML::Node(YAML::NodeType::Map);
  const std::vector<std::string> parts = splitNamespace(ns);
  if (parts.empty()) {
    mergeNode(tree, content);
    return;
  }
  YAML::Node existing = YAML::Clone(tree);
  YAML::Node merged(YAML::NodeType::Map);
  mergeNode(merged, content);
  // Merge into the namespace: take what is there, merge the file over it, write it back.
  YAML::Node current(YAML::NodeType::Map);
  {
    YAML::Node probe = existing;
    bool present = true;
    for (const std::string& part : parts) {
      if (!probe.IsMap() || !probe[part].IsMap()) {
        present = false;
        break;
      }
      YAML::Node next = probe[part];
      probe.reset(next);
    }
    if (present) mergeNode(current, probe);
  }
  mergeNode(current, merged);
  setAt(tree, parts, 0, current);
}

}  // namespace nav
}  // namespace marl_mrta
