#include "xpersif/core/common/package_path.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace xpersif::core {

namespace fs = std::filesystem;

namespace {

const std::string kScheme = "package://";
constexpr int kMaxDepth = 8;  // rospack's crawl has no limit; a bound keeps a path entry like / from taking minutes

/// The <name> of the package.xml in @p dir, if it has one.
std::optional<std::string> packageName(const fs::path& dir) {
  std::ifstream in(dir / "package.xml");
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  static const std::regex name_element(R"(<name>\s*([^<\s]+)\s*</name>)");
  std::smatch match;
  const std::string xml = text.str();
  if (!std::regex_search(xml, match, name_element)) return std::string();
  return match[1].str();
}

/// The directory of package @p name at or below @p dir, depth first in name order (a stable answer for duplicates).
std::optional<fs::path> findPackage(const fs::path& dir, const std::string& name, int depth) {
  if (const auto found = packageName(dir)) {
    if (*found == name) return dir;
    return std::nullopt;  // another package: nothing below it is searched
  }
  if (depth >= kMaxDepth) return std::nullopt;
  std::error_code ec;
  std::vector<fs::path> children;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string leaf = it->path().filename().string();
    if (leaf.empty() || leaf[0] == '.' || !it->is_directory(ec)) continue;
    children.push_back(it->path());
  }
  std::sort(children.begin(), children.end());
  for (const auto& child : children) {
    if (auto found = findPackage(child, name, depth + 1)) return found;
  }
  return std::nullopt;
}

}  // namespace

std::string rosPackagePath() {
  const char* path = std::getenv("ROS_PACKAGE_PATH");
  return path ? path : "";
}

bool isPackageUri(const std::string& path) { return path.rfind(kScheme, 0) == 0; }

std::string resolvePackageUri(const std::string& uri, const std::string& ros_package_path) {
  if (!isPackageUri(uri)) throw std::invalid_argument("'" + uri + "' is not a package:// URI");
  const std::string rest = uri.substr(kScheme.size());
  const auto slash = rest.find('/');
  if (slash == 0 || slash == std::string::npos || slash + 1 == rest.size()) {
    throw std::invalid_argument("'" + uri + "' must be package://PACKAGE/PATH, a package's name and a file in it");
  }
  const std::string name = rest.substr(0, slash), inside = rest.substr(slash + 1);
  std::stringstream entries(ros_package_path);
  std::string entry;
  while (std::getline(entries, entry, ':')) {
    if (entry.empty()) continue;
    if (const auto dir = findPackage(fs::path(entry), name, 0)) return (*dir / inside).lexically_normal().string();
  }
  throw std::invalid_argument("'" + uri + "' names the package '" + name + "', which is not on ROS_PACKAGE_PATH (" +
                              (ros_package_path.empty() ? std::string("unset or empty") : "'" + ros_package_path + "'") +
                              "); source the workspace's setup, or give the file's path");
}

std::string resolveNamedFile(const std::string& named, const std::string& base_dir) {
  if (isPackageUri(named)) return resolvePackageUri(named, rosPackagePath());
  return !named.empty() && named[0] == '/' ? named : base_dir + "/" + named;
}

}  // namespace xpersif::core
