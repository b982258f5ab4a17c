// xpersif_export: XPERSIF traces (bags) -> CSV tables. Schema: doc/traces.md; exit codes as every tool of the
// package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <iostream>
#include <regex>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/bag_tools.h"

#include "tool_command_line.h"

namespace {
using namespace xpersif::core;
constexpr int kOk = kExitOk, kBadBag = kExitBadInput, kOutput = kExitOutput;
}  // namespace

int main(int argc, char** argv) {
  xpersif::traces::ExportOptions options;
  std::vector<std::string> inputs;
  CLI::App app("XPERSIF traces (bags) to CSV tables: OUT_DIR/experiments.csv, poses.csv (and features.csv); "
               "see doc/traces.md",
               "xpersif_export");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("written", "an unexpected error") +
                                    " A bag that is missing or unreadable is named.");
  app.add_option("-o,--out", options.out_dir, "where the CSV files go")->capture_default_str();
  app.add_flag("--features", options.features, "also features.csv: every object's features per frame");
  app.add_flag_callback("--no-poses", [&options] { options.poses = false; }, "no poses.csv");
  app.add_option("--frames", options.frames_regex, "the tf frames of poses.csv, a regular expression")
      ->capture_default_str();
  app.add_option("--pose-period", options.pose_period, "seconds of simulated time between pose rows (0: every one)")
      ->check(xpersif::tools::finiteNumber(0, 1e9))
      ->capture_default_str();
  app.add_option("--experiments-topic", options.experiments_topic, "the topic of the experiment records")
      ->capture_default_str();
  app.add_option("BAG_OR_RUN_DIR", inputs, "bags, or run directories whose bags are read")->required();
  if (const auto done = xpersif::tools::parse(app, argc, argv)) return *done;
  try {
    std::regex check(options.frames_regex);
  } catch (const std::regex_error& e) {
    std::cerr << "xpersif_export: --frames '" << options.frames_regex << "' is not a regular expression: " << e.what()
              << "\n" << app.help();
    return kExitUsage;
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
