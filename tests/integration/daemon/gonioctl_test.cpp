// gonioctl against a real goniod: tables, --json, exit codes, export to a file, and the
// README's main job (`gonioctl demo`) end to end.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <numbers>

#include "gonio/test/daemon_harness.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/twin/bsdf_io.hpp"

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

// The README's walk-through scan goes through the specular peak: the mirrored angles near
// retro-reflection (the arms' collision zone) and beyond are never measured. Its IS-SA and
// SSDD tables are written all the same, the gap left unmeasured, and the twin's readers
// give back the stored values where the scan measured.
TEST(Gonioctl, TablesOfTheWalkThroughScanRoundTrip) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const std::string sd = dir.path.string();
  ASSERT_EQ(gonioctl({"--state-dir", sd, "sample", "create", "tile", "--bsdf", kTrueSample}).code, 0);
  auto r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--grid", "in=45;out=-30:80:2",
                     "--wavelengths", "450,550,650", "--watch"});
  ASSERT_EQ(r.code, 0) << r.out;
  auto c = g.unix_conn();
  const auto points = c.call("scan.points", json{{"scan", 1}, {"offset", 0}, {"limit", 1000}})["points"];
  ASSERT_EQ(points.size(), 56u);
  for (const std::string format : {"ssdd", "bsdf"}) {
    SCOPED_TRACE(format);
    const auto file = (dir.path / ("scan." + format)).string();
    r = gonioctl({"--state-dir", sd, "scan", "export", "1", "--format", format, "-o", file});
    ASSERT_EQ(r.code, 0) << r.out;
    std::ifstream in(file);
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(text.find("theta_i = 45 deg: theta_r = -80 to -32 deg"), std::string::npos) << text.substr(0, 800);
    const auto parts = twin::read_bsdf_file(file);
    ASSERT_TRUE(parts.brdf);
    const auto& t = *parts.brdf;
    std::vector<double> f(t.channels());
    const auto at = [&](const Geometry& geo) {
      const auto a = geo.incident_direction(), b = geo.receiving_direction();
      return t.coords({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
    };
    for (const auto& p : points) {
      const auto geo = p["planned"].get<Geometry>();
      const auto q = at(geo);
      EXPECT_TRUE(t.covers(q)) << geo.to_string();
      t.interpolate(q, f);
      const auto beta = p["measured"]["values"];
      if (format == "ssdd") {
        // The stored β, as f = β/π per channel (negative noise reads 0).
        for (std::size_t k = 0; k < f.size(); ++k)
          EXPECT_NEAR(f[k], std::max(0.0, beta[k].get<double>()) / std::numbers::pi, 1e-7 * (1 + f[k]))
              << geo.to_string();
      } else {
        EXPECT_GT(f[0], 0) << geo.to_string();  // Y of the three channels
      }
    }
    for (double tr : {-32.0, -45.0, -60.0, -80.0})
      EXPECT_FALSE(t.covers(at(Geometry::in_plane(45, tr)))) << tr;
  }
}

// The verdict where people look: `scan get`, `scan watch` and `submit --watch` end with the
// verdict line and the scan's alerts as alert.list has them; --exit-status turns the verdict
// into an exit code for scripts (10 out_of_tolerance, 0 agrees).
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
