// The one error of a bad parameter, for navigation and the simulator alike: what() is one line
// "<where>: <problem>", where names the parameter ("/simulator/robots") or file.
#pragma once

#include <stdexcept>
#include <string>

namespace marl_mrta {
namespace nav {

class ParamError : public std::runtime_error {
 public:
  ParamError(const std::string& where, const std::string& problem)
      : std::runtime_error(where + ": " + problem), where_(where), problem_(problem) {}
  const std::string& where() const { return where_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string where_, problem_;
};

}  // namespace nav
}  // namespace marl_mrta
