#include "xpersif/core/common/command_line.h"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace xpersif::core {

namespace fs = std::filesystem;

std::uint64_t parseWholeNumber(const std::string& option, const std::string& text, std::uint64_t lo, std::uint64_t hi) {
  const std::string range = std::to_string(lo) + ".." + std::to_string(hi);
  bool digits = !text.empty() && text.size() <= 20;
  for (char c : text) digits = digits && c >= '0' && c <= '9';
  if (!digits) throw UsageError(option + " is '" + text + "'; it must be a whole number in " + range);
  errno = 0;
  const unsigned long long value = std::strtoull(text.c_str(), nullptr, 10);
  if (errno == ERANGE || value < lo || value > hi) {
    throw UsageError(option + " is " + text + "; it must be a whole number in " + range);
  }
  return value;
}

double parseRealNumber(const std::string& option, const std::string& text, double lo, double hi) {
  auto refuse = [&](const std::string& shown) {
    char bounds[96];
    std::snprintf(bounds, sizeof bounds, "%g..%g", lo, hi);
    return UsageError(option + " is " + shown + "; it must be a finite number in " + bounds);
  };
  if (text.empty() || text.size() > 64 || std::isspace(static_cast<unsigned char>(text[0]))) throw refuse("'" + text + "'");
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(value)) throw refuse("'" + text + "'");
  if (value < lo || value > hi) throw refuse(text);
  return value;
}

std::string checkReadableFile(const std::string& what, const std::string& path) {
  if (path.empty()) return what + ": the path is empty";
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) return what + " " + path + " does not exist";
  if (fs::is_directory(status)) return what + " " + path + " is a directory, not a file";
  if (!fs::is_regular_file(status)) return what + " " + path + " is not a regular file";
  if (::access(path.c_str(), R_OK) != 0) return what + " " + path + " cannot be read: " + std::strerror(errno);
  return "";
}

std::string checkWritableDirectory(const std::string& what, const std::string& path) {
  if (path.empty()) return what + ": the path is empty";
  std::error_code ec;
  fs::path p = fs::absolute(path, ec);
  if (ec) return what + " " + path + ": " + ec.message();
  // The directory itself, or the nearest ancestor that exists (the tool creates the rest).
  while (!fs::exists(p, ec) && p.has_parent_path() && p != p.parent_path()) p = p.parent_path();
  if (!fs::is_directory(p, ec)) {
    return what + " " + path + (p == fs::absolute(path, ec) ? " is not a directory" : ": " + p.string() + " is not a directory");
  }
  if (::access(p.c_str(), W_OK | X_OK) != 0) {
    return what + " " + path + " cannot be written" + (p == fs::absolute(path, ec) ? "" : " (in " + p.string() + ")") +
           ": " + std::strerror(errno);
  }
  return "";
}

}  // namespace xpersif::core
