// export_material: light a format cannot hold is refused, not dropped. glTF (as written)
// and MERL hold reflection only, so a transmitting lobe is refused naming it and the
// format, and no file is written.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <unistd.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/material.hpp"

namespace gonio::twin {
namespace {

namespace fs = std::filesystem;

TEST(Export, TransmissionIsRefusedByTheReflectionOnlyFormats) {
  const auto dir = fs::temp_directory_path() / ("gonio-export-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const auto grid = WavelengthGrid::parse("400:700:50");
  const std::pair<material::Format, const char*> formats[] = {{material::Format::gltf, "glTF 2.0"},
                                                               {material::Format::merl, "MERL"}};
  for (const char* spec : {"dielectric:alpha=0.1,ior=1.5", "lambert:albedo=0.2+dielectric:alpha=0.3,ior=1.4"}) {
    for (const auto& [format, name] : formats) {
      const auto path = (dir / "out").string();
      try {
        material::export_material(spec, format, path, grid);
        ADD_FAILURE() << spec << " was written as " << name;
      } catch (const Error& e) {
        EXPECT_EQ(e.code(), Errc::unsupported) << e.what();
        EXPECT_EQ(e.field(), "bsdf.dielectric") << e.what();
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      }
      EXPECT_FALSE(fs::exists(path)) << spec;
    }
  }
  // Reflection alone passes the check (MERL: no fit, quick).
  const auto path = (dir / "paint.binary").string();
  const auto r = material::export_material("lambert:albedo=0.3+coat:alpha=0.2,ior=1.5", material::Format::merl, path, grid);
  EXPECT_TRUE(fs::exists(path));
  ASSERT_TRUE(r.merl);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace gonio::twin
