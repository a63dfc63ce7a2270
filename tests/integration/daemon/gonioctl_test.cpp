// gonioctl against a real goniod: tables, --json, exit codes, export to a file, and the
// README's main job (`gonioctl demo`) end to end.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>

#include <fmt/format.h>
#include <numbers>

#include "gonio/test/daemon_harness.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace gonio::test {
namespace {

ProgramRun gonioctl(const std::vector<std::string>& args) { return run_program("gonioctl", args); }

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
  EXPECT_NE(r.out.find(fmt::format("wrote {} (5 points, csv, {} bytes)", file, fs::file_size(file))), std::string::npos)
      << r.out;
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
TEST(Gonioctl, VerdictLineAlertCountAndExitStatus) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const std::string sd = dir.path.string();
  ASSERT_EQ(gonioctl({"--state-dir", sd, "sample", "create", "tile", "--bsdf", kTrueSample}).code, 0);
  ASSERT_EQ(gonioctl({"--state-dir", sd, "sample", "create", "grey", "--bsdf", "lambert:albedo=0.3",
                      "--tolerance", "0.02"}).code, 0);
  const std::string grid = "in=45;out=-30:80:5";
  // The catalogue is the mock's true sample: the scan agrees, and --exit-status says 0.
  auto r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--grid", grid, "--watch", "--exit-status"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("verdict: agrees over"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("alerts: none"), std::string::npos) << r.out;
  // Catalogued at half the true albedo: out of tolerance, a sample parameter named.
  r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "grey", "--grid", grid, "--watch", "--exit-status"});
  EXPECT_EQ(r.code, 10) << r.out;
  EXPECT_NE(r.out.find("verdict: out_of_tolerance over"), std::string::npos) << r.out;
  EXPECT_EQ(gonioctl({"--state-dir", sd, "scan", "watch", "2"}).code, 0);  // without the flag: completed is 0
  // The alert count of a finished scan is alert.list's, not the notifications seen.
  r = gonioctl({"--state-dir", sd, "--json", "alert", "list", "--scan", "2"});
  ASSERT_EQ(r.code, 0) << r.out;
  const auto standing = json::parse(r.out).size();
  ASSERT_GT(standing, 0u);
  r = gonioctl({"--state-dir", sd, "scan", "watch", "2", "--exit-status"});
  EXPECT_EQ(r.code, 10) << r.out;
  EXPECT_NE(r.out.find(fmt::format("alerts {}\n", standing)), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(fmt::format("alerts: {} standing", standing)), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "get", "2", "--exit-status"});
  EXPECT_EQ(r.code, 10) << r.out;
  EXPECT_NE(r.out.find("verdict: out_of_tolerance"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("sample grey (2)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wavelengths 400:700:10 nm"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "get", "1", "--exit-status"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("verdict: agrees"), std::string::npos) << r.out;
  // --exit-status means nothing without the watch: refused before anything is queued.
  r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "tile", "--grid", grid, "--exit-status"});
  EXPECT_EQ(r.code, 2) << r.out;
  r = gonioctl({"--state-dir", sd, "--json", "scan", "list"});
  EXPECT_EQ(json::parse(r.out).size(), 2u) << r.out;
  // People's output: the instrument's state first, counters on request; sample names in the
  // list, a chosen channel in the points.
  r = gonioctl({"--state-dir", sd, "info"});
  EXPECT_NE(r.out.find("instrument: idle, connected"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fault latch: clear"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("governor."), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "info", "--verbose"});
  EXPECT_NE(r.out.find("governor."), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "list"});
  EXPECT_NE(r.out.find("grey"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "points", "1", "--wavelength", "620", "--limit", "1"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(" 620 "), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "points", "1", "--wavelength", "625"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no channel at 625 nm; the scan measured 400:700:10 nm"), std::string::npos) << r.out;
}

// Errors that say what to do next.
TEST(Gonioctl, ErrorsNameTheNextStep) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const std::string sd = dir.path.string();
  ASSERT_EQ(gonioctl({"--state-dir", sd, "sample", "create", "paint", "--bsdf", kTrueSample}).code, 0);
  auto r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "pain", "--geometry", "45/0"});
  EXPECT_EQ(r.code, 5) << r.out;
  EXPECT_NE(r.out.find("did you mean 'paint'?"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "call", "scan.gett"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("did you mean 'scan.get'?"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scna", "list"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown command 'scna' (did you mean 'scan'?)"), std::string::npos) << r.out;
  r = gonioctl({"--state-dir", sd, "scan", "lsit"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("did you mean 'list'?"), std::string::npos) << r.out;
  // --tolerance is the sample's acceptance limit; the adaptive curve's error is --curve-error
  // (the old spelling still works, with a note, but not beside the new one).
  r = gonioctl({"--state-dir", sd, "scan", "submit", "--sample", "paint", "--grid", "in=45;out=0:40:10", "--adaptive",
                "curve", "--tolerance", "0.05", "--curve-error", "0.05"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("give --curve-error alone"), std::string::npos) << r.out;
  // A token file that is not there is that, not "a token is needed".
  const auto missing = (dir.path / "no.token").string();
  r = gonioctl({"--state-dir", sd, "--connect", g.uri("tcp://"), "--token-file", missing, "info"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("file not found: " + missing), std::string::npos) << r.out;
  // No goniod on the socket: start it, or point at its state dir.
  r = gonioctl({"--state-dir", (dir.path / "nowhere").string(), "info"});
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("cannot connect to unix:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--state-dir"), std::string::npos) << r.out;
}

// goniod's instrument tables: a driver name it does not know is an error naming the key and
// the near name, with --mock or without; --mock replacing a hardware table warns.
TEST(Gonioctl, GoniodConfigTyposAndMockReplacementAreSaid) {
  TempDir dir;
  const auto typo = dir.path / "typo.toml", hw = dir.path / "hw.toml";
  std::ofstream(typo) << "[instrument.motion]\ndriver = \"mokc\"\nsample = \"lambert:albedo=0.3\"\n";
  std::ofstream(hw) << "[instrument.motion]\ndriver = \"modbus\"\n\n[instrument.photometer]\n"
                       "driver = \"scpi-tcp\"\nhost = \"127.0.0.1\"\n";
  for (const bool mock : {true, false}) {
    const auto r = run_program("goniod", mock ? std::vector<std::string>{"--mock", "--check-config", typo.string()}
                                      : std::vector<std::string>{"--check-config", typo.string()});
    EXPECT_EQ(r.code, 2) << mock << r.out;
    EXPECT_NE(r.out.find("instrument.motion.driver: 'mokc' is not a driver (did you mean 'mock'?)"), std::string::npos)
        << mock << r.out;
    EXPECT_NE(r.out.find("modbus, mock, scpi-serial"), std::string::npos) << r.out;
  }
  const auto r = run_program("goniod", {"--mock", "--check-config", hw.string()});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("# warning: --mock replaces the configured instrument (motion driver 'modbus'"), std::string::npos)
      << r.out;
}

TEST(Gonioctl, DemoRunsTheMainJobEndToEnd) {
  TempDir dir;
  const auto demo = dir.path / "demo";
  const auto r = gonioctl({"demo", "--demo-dir", demo.string(), "--time-scale", "0"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("56 points"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("divergence summary: 0 of 56 points out of tolerance"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("verdict: agrees over 56 points"), std::string::npos) << r.out;
  // Every point undecided on its own and a scan that agrees: the demo says why.
  EXPECT_NE(r.out.find("why it agrees while 56 points are undecided"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("goniod stopped (exit 0)"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(demo / "demo.png"));
  std::ifstream png(demo / "demo.png", std::ios::binary);
  char magic[8] = {};
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

}  // namespace
}  // namespace gonio::test
