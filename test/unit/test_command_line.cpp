// The command-line tools' shared checks: numbers written in full, readable files, writable directories.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "xpersif/core/common/command_line.h"

using namespace xpersif::core;

TEST(CommandLine, WholeNumbersAreWrittenInFullAndInRange) {
  EXPECT_EQ(parseWholeNumber("--seed", "0"), 0u);
  EXPECT_EQ(parseWholeNumber("--seed", "18446744073709551615"), UINT64_MAX);
  EXPECT_EQ(parseWholeNumber("--experiments", "12", 1, 100), 12u);
  for (const char* bad : {"abc", "", "12abc", "-1", "+3", " 3", "1e3", "3.0", "0x10", "18446744073709551616"}) {
    try {
      parseWholeNumber("--seed", bad);
      ADD_FAILURE() << "'" << bad << "' was taken";
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--seed is ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find("it must be a whole number in 0..18446744073709551615"), std::string::npos);
    }
  }
  try {
    parseWholeNumber("--experiments", "101", 1, 100);
    ADD_FAILURE();
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "--experiments is 101; it must be a whole number in 1..100");
  }
}

TEST(CommandLine, RealNumbersAreFiniteWrittenInFullAndInRange) {
  EXPECT_DOUBLE_EQ(parseRealNumber("--pose-period", "0.25"), 0.25);
  EXPECT_DOUBLE_EQ(parseRealNumber("OFFSET", "-1e-2"), -0.01);
  for (const char* bad : {"abc", "", "nan", "inf", "-inf", "1e999", "0.1x", " 1"}) {
    EXPECT_THROW(parseRealNumber("--pose-period", bad), UsageError) << bad;
  }
  try {
    parseRealNumber("--pose-period", "-2", 0, 3600);
    ADD_FAILURE();
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "--pose-period is -2; it must be a finite number in 0..3600");
  }
}

TEST(CommandLine, FilesAndDirectoriesAreCheckedWithASentence) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("xpersif_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string file = (dir / "kb.db").string();
  std::ofstream(file) << "x";
  EXPECT_EQ(checkReadableFile("knowledge base", file), "");
  EXPECT_EQ(checkReadableFile("knowledge base", (dir / "none.db").string()),
            "knowledge base " + (dir / "none.db").string() + " does not exist");
  EXPECT_EQ(checkReadableFile("knowledge base", dir.string()), "knowledge base " + dir.string() + " is a directory, not a file");
  EXPECT_EQ(checkWritableDirectory("output directory", dir.string()), "");
  EXPECT_EQ(checkWritableDirectory("output directory", (dir / "new/deeper").string()), "") << "created by the tool";
  EXPECT_NE(checkWritableDirectory("output directory", file).find("is not a directory"), std::string::npos);
  if (::geteuid() != 0) {  // root may read and write anything
    ::chmod(file.c_str(), 0);
    EXPECT_NE(checkReadableFile("knowledge base", file).find("cannot be read: Permission denied"), std::string::npos);
    ::chmod(dir.c_str(), 0500);
    EXPECT_NE(checkWritableDirectory("output directory", dir.string()).find("cannot be written"), std::string::npos);
    ::chmod(dir.c_str(), 0700);
  }
  fs::remove_all(dir);
}
