/**
 * @file command_line.h
 * @brief What every command-line tool of the package shares: its exit codes, and checks of arguments and files
 *        that turn a bad number, a missing file or a directory without permission into one sentence. ROS-free.
 *
 * Exit codes (doc/exit-codes.md), the same for `xpersif`, `xpersif_report`, `xpersif_export`,
 * `xpersif_train_offline`, `xpersif_recover_bag`, `xpersif_experiment` and `scripts/run.sh`:
 *   0 done; 1 it ran and failed (a phase, the report, the system did not answer); 2 usage: an unknown option, a
 *   missing or malformed argument (also a bad experiment file: nothing started); 3 a bad input file: missing,
 *   unreadable or corrupt (knowledge base, bag, world, model); 4 the output cannot be written; 5 a run (`xpersif run`,
 *   `rerun`, `xpersif_experiment`, `scripts/run.sh`) stopped on a cause that fails every experiment: a perceiving
 *   component refuses to work, or experiments kept failing for one cause (running it again changes nothing).
 */
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace xpersif::core {

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;
constexpr int kExitBadInput = 3;
constexpr int kExitOutput = 4;
constexpr int kExitRepeatingCause = 5;  ///< a run stopped on a cause that fails every experiment (RunLoop's code)

/// A malformed command line; what() is the sentence (exit kExitUsage).
class UsageError : public std::invalid_argument {
 public:
  explicit UsageError(const std::string& what) : std::invalid_argument(what) {}
};

/// A whole number written in full ("12"; not "12abc", "-1", "1e3" or ""), lo..hi. @throws UsageError naming @p option
std::uint64_t parseWholeNumber(const std::string& option, const std::string& text, std::uint64_t lo = 0,
                               std::uint64_t hi = UINT64_MAX);
/// A finite real number written in full, lo..hi. @throws UsageError naming @p option
double parseRealNumber(const std::string& option, const std::string& text, double lo = -1e300, double hi = 1e300);

/// "" when @p path is an existing regular file this process may read, else a sentence naming @p what and the path.
std::string checkReadableFile(const std::string& what, const std::string& path);
/// "" when @p path is a directory this process may write into, or does not exist but can be created (its nearest
/// existing ancestor is a writable directory), else a sentence.
std::string checkWritableDirectory(const std::string& what, const std::string& path);

}  // namespace xpersif::core
