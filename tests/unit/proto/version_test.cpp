// gonio/proto/version.hpp agrees with project(VERSION ...) in the top-level CMakeLists.txt,
// and its string and numbers agree with each other.
#include "gonio/proto/version.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace gonio::proto {
namespace {

TEST(Version, MatchesTheProjectVersion) {
  std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/CMakeLists.txt");
  ASSERT_TRUE(in) << "cannot read the top-level CMakeLists.txt";
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  std::smatch m;
  ASSERT_TRUE(std::regex_search(s, m, std::regex(R"(project\(gonio\s+VERSION\s+([0-9.]+))")));
  EXPECT_EQ(std::string(kVersion), m[1].str());
}

TEST(Version, NumbersSpellTheString) {
  const std::string joined = std::to_string(kVersionMajor) + "." + std::to_string(kVersionMinor) +
                             "." + std::to_string(kVersionPatch);
  EXPECT_EQ(std::string(kVersion), joined);
  EXPECT_EQ(std::string_view(GONIO_VERSION_STRING), kVersion);
}

}  // namespace
}  // namespace gonio::proto
