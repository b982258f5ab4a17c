/**
 * @file tool_command_line.h
 * @brief One convention for every command-line tool of the package, on CLI11 (doc/exit-codes.md):
 *        `-h`/`--help` prints the usage (with the exit codes) on stdout and exits 0; a bad argument prints one
 *        sentence and the usage on stderr and exits 2 (core::kExitUsage).
 */
#pragma once

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "xpersif/core/common/command_line.h"

namespace xpersif::tools {

/// The exit codes every tool shares (core/common/command_line.h), for the end of a usage; @p failed "" for a tool
/// that never exits 1.
inline std::string exitCodes(const std::string& done = "done", const std::string& failed = "it ran and failed") {
  return "Exit codes: 0 " + done + (failed.empty() ? "" : "; 1 " + failed) +
         "; 2 usage (an unknown option, a missing or malformed argument); 3 a bad input file (missing, unreadable "
         "or corrupt); 4 the output cannot be written (doc/exit-codes.md).";
}

/// An application with the package's help flag and the exit codes as its footer.
inline void describe(CLI::App& app, const std::string& exit_codes) {
  app.set_help_flag("-h,--help", "print this usage and exit");
  app.footer(exit_codes);
  app.get_formatter()->column_width(34);
}

/// The sentence for a refused command line. CLI11 checks required arguments before it looks for words it does not
/// know, so `tool --bogus` would be told "--database is required": a word nobody asked for is named first, in the
/// order typed (CLI11 lists them backwards).
inline std::string firstProblem(const CLI::App& app, const CLI::ParseError& e, int argc, const char* const* argv) {
  if (!dynamic_cast<const CLI::RequiredError*>(&e) && !dynamic_cast<const CLI::ExtrasError*>(&e)) return e.what();
  std::vector<std::string> unknown;
  for (const CLI::App* command = &app; command != nullptr;) {
    for (const auto& word : command->remaining()) unknown.push_back(word);
    const auto chosen = command->get_subcommands();
    command = chosen.empty() ? nullptr : chosen.front();
  }
  if (unknown.empty()) return e.what();
  std::string words;
  for (int i = 1; i < argc; ++i) {  // in the order they were typed
    if (std::find(unknown.begin(), unknown.end(), argv[i]) != unknown.end()) words += std::string(" ") + argv[i];
  }
  return "The following argument" + std::string(unknown.size() > 1 ? "s were" : " was") + " not expected:" + words;
}

/// Parses the command line into @p app: std::nullopt when the tool should go on, else the exit code — 0 after
/// --help (the usage of the subcommand asked about, on stdout), 2 after a bad argument (one sentence naming the
/// tool, then the usage, on stderr).
inline std::optional<int> parse(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return core::kExitOk;
  } catch (const CLI::ParseError& e) {
    std::cerr << app.get_name() << ": " << firstProblem(app, e, argc, argv) << "\n" << app.help();
    return core::kExitUsage;
  }
  return std::nullopt;
}

/// The same for a command line already split into words, the program's name first.
inline std::optional<int> parse(CLI::App& app, const std::vector<std::string>& words) {
  std::vector<const char*> argv;
  for (const auto& w : words) argv.push_back(w.c_str());
  return parse(app, static_cast<int>(argv.size()), argv.data());
}

/// A validator: a whole number written in full, lo..hi ("'12abc' is not a whole number in 0..9").
inline CLI::Validator wholeNumber(std::uint64_t lo = 0, std::uint64_t hi = UINT64_MAX) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        try {
          core::parseWholeNumber("", text, lo, hi);
        } catch (const core::UsageError&) {
          return "'" + text + "' is not a whole number in " + std::to_string(lo) + ".." + std::to_string(hi);
        }
        return "";
      },
      "WHOLE");
}

/// A validator: a finite real number written in full, lo..hi (CLI11's Range would take "nan" and "inf").
inline CLI::Validator finiteNumber(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        try {
          core::parseRealNumber("", text, lo, hi);
        } catch (const core::UsageError&) {
          char bounds[96];
          std::snprintf(bounds, sizeof bounds, "%g..%g", lo, hi);
          return "'" + text + "' is not a finite number in " + bounds;
        }
        return "";
      },
      "NUMBER");
}

}  // namespace xpersif::tools
