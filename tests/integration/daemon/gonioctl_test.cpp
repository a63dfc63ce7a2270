// gonioctl against a real goniod: tables, --json, exit codes, export to a file, and the
// README's main job (`gonioctl demo`) end to end.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

struct Run {
  int code = -1;
  std::string out;
};

// Runs gonioctl with `args`; stdout and stderr together.
Run gonioctl(const std::vector<std::string>& args) {
  std::string cmd = std::string(GONIO_BIN_DIR) + "/gonioctl";
  for (const auto& a : args) {
    cmd += " '";
    for (char ch : a) cmd += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
    cmd += "'";
  }
  cmd += " 2>&1";
  Run r;
  FILE* p = ::popen(cmd.c_str(), "r");
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(Gonioctl, CommandsTablesJsonAndExitCodes) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const std::string sd = dir.path.string();
  auto r = gonioctl({"--state-dir", sd, "sample", "create", "tile", "--bsdf", kTrueSample});
  ASSERT_EQ(r.code, 0) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--grid", "in=45;out=-30:50:20", "--watch"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("completed"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("5 of 5 points"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "--json", "scan", "get", "1"});
  ASSERT_EQ(r.code, 0);
  EXPECT_EQ(json::parse(r.out)["state"], "completed");
  r = gonioctl({"--state-dir", sd, "scan", "points", "1"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("measured"), std::string::npos);
  const auto file = (dir.path / "out.csv").string();
  r = gonioctl({"--state-dir", sd, "scan", "export", "1", "--format", "csv", "-o", file});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::file_size(file) > 100);
  // A fitted material written for a renderer: a scan without a fit is refused (exit 6),
  // then the fit's Mitsuba scene is written to a file.
  const auto xml = (dir.path / "tile.xml").string();
  EXPECT_EQ(gonioctl({"--state-dir", sd, "scan", "material", "1", "--format", "mitsuba", "-o", xml}).code, 6);
  ASSERT_EQ(gonioctl({"--state-dir", sd, "scan", "fit", "1", "--model", "lambert:albedo=?", "--samples", "1024"}).code, 0);
  r = gonioctl({"--state-dir", sd, "scan", "material", "1", "--format", "mitsuba", "-o", xml});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("wrote " + xml), std::string::npos) << r.out;
  std::ifstream in(xml);
  const std::string scene((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(scene.find(R"(<bsdf type="diffuse">)"), std::string::npos) << scene;
  // Exit codes follow the server's error.
  EXPECT_EQ(gonioctl({"--state-dir", sd, "scan", "get", "99"}).code, 5);
  r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--geometry", "45/-88"});
  EXPECT_EQ(r.code, 8) << r.out;
  EXPECT_NE(r.out.find("geometries[0]"), std::string::npos) << r.out;
  EXPECT_EQ(gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--geometry", "45/-30", "--repeats", "0"}).code, 2);
  EXPECT_EQ(gonioctl({"--state-dir", sd, "scan", "resume", "1"}).code, 6);
  EXPECT_EQ(gonioctl({"--state-dir", (dir.path / "nowhere").string(), "info"}).code, 3);
  EXPECT_EQ(gonioctl({"--state-dir", sd, "frobnicate"}).code, 2);
  // Over TCP it logs in with the state dir's admin token; a wrong token is refused.
  r = gonioctl({"--state-dir", sd, "--connect", g.uri("tcp://"), "--json", "info"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json::parse(r.out)["you"]["role"], "admin");
  EXPECT_EQ(gonioctl({"--state-dir", sd, "--connect", g.uri("tcp://"), "--token", "nope", "info"}).code, 4);
}

TEST(Gonioctl, DemoRunsTheMainJobEndToEnd) {
  TempDir dir;
  const auto demo = dir.path / "demo";
  const auto r = gonioctl({"demo", "--demo-dir", demo.string(), "--time-scale", "0"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("56 points"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("divergence summary: 0 of 56 points out of tolerance"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("verdict: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("goniod stopped (exit 0)"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(demo / "demo.png"));
  std::ifstream png(demo / "demo.png", std::ios::binary);
  char magic[8] = {};
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

}  // namespace
}  // namespace gonio::test
