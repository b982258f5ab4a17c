#include "xpersif/component/parameter_reader.h"

#include <set>

namespace xpersif {

std::vector<std::string> parametersSetUnder(const ros::NodeHandle& private_nh) {
  std::vector<std::string> all;
  if (!ros::param::getParamNames(all)) return {};
  const std::string prefix = private_nh.getNamespace() + "/";
  std::set<std::string> names;
  for (const auto& full : all) {
    if (full.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = full.substr(prefix.size());
    names.insert(rest.substr(0, rest.find('/')));
  }
  return {names.begin(), names.end()};
}

}  // namespace xpersif
