// xpersif_export: XPERSIF traces (bags) -> CSV tables. Schema: doc/traces.md; exit codes as every tool of the
// package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <iostream>
#include <regex>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/bag_tools.h"

namespace {
using namespace xpersif::core;
constexpr int kOk = kExitOk, kBadBag = kExitBadInput, kUsage = kExitUsage, kOutput = kExitOutput;

int usage(const std::string& error) {
  if (!error.empty()) std::cerr << "xpersif_export: " << error << "\n";
  std::cerr << "usage: xpersif_export [-o OUT_DIR] [--features] [--no-poses] [--frames REGEX] [--pose-period S]\n"
               "                      [--experiments-topic T] BAG_OR_RUN_DIR...\n"
               "writes OUT_DIR/experiments.csv, poses.csv (and features.csv); see doc/traces.md\n"
               "exit: 0 written, 2 usage, 3 a bag is missing or unreadable (the message names it), 4 output not writable\n";
  return kUsage;
}
}  // namespace

int main(int argc, char** argv) {
  xpersif::traces::ExportOptions options;
  std::vector<std::string> inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) throw UsageError(std::string(name) + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "-o" || a == "--out") options.out_dir = value("-o");
      else if (a == "--features") options.features = true;
      else if (a == "--no-poses") options.poses = false;
      else if (a == "--frames") options.frames_regex = value("--frames");
      else if (a == "--pose-period") options.pose_period = parseRealNumber("--pose-period", value("--pose-period"), 0, 1e9);
      else if (a == "--experiments-topic") options.experiments_topic = value("--experiments-topic");
      else if (a == "-h" || a == "--help") return usage(""), kOk;
      else if (!a.empty() && a[0] == '-') return usage("unknown option " + a);
      else inputs.push_back(a);
    } catch (const std::exception& e) {
      return usage(e.what());
    }
  }
  if (inputs.empty()) return usage("give at least one bag or run directory");
  try {
    std::regex check(options.frames_regex);
  } catch (const std::regex_error& e) {
    return usage("--frames '" + options.frames_regex + "' is not a regular expression: " + e.what());
  }
  for (const auto& input : inputs) {
    std::error_code ec;
    if (std::filesystem::is_directory(input, ec)) continue;
    const std::string why = checkReadableFile("bag", input);
    if (!why.empty()) {
      std::cerr << "xpersif_export: " << why << "\n";
      return kBadBag;
    }
  }
  if (const std::string why = checkWritableDirectory("output directory", options.out_dir); !why.empty()) {
    std::cerr << "xpersif_export: " << why << "\n";
    return kOutput;
  }
  try {
    const auto files = xpersif::traces::bagFiles(inputs);
    const auto s = xpersif::traces::exportCsv(files, options);
    std::cout << "read " << s.bags << " bag(s): " << s.experiments << " experiments, " << s.poses << " poses";
    if (options.features) std::cout << ", " << s.features << " feature rows";
    std::cout << "\n";
    for (const auto& f : s.files_written) std::cout << "wrote " << f << "\n";
    return kOk;
  } catch (const xpersif::traces::BagError& e) {
    std::cerr << "xpersif_export: " << e.what() << "\n";
    return kBadBag;
  } catch (const xpersif::traces::OutputError& e) {
    std::cerr << "xpersif_export: " << e.what() << "\n";
    return kOutput;
  } catch (const std::exception& e) {  // anything else a library throws: still a sentence, never a crash
    std::cerr << "xpersif_export: unexpected error: " << e.what() << "\n";
    return kExitFailed;
  }
}
