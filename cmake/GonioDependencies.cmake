# Every third-party dependency, found once. All come from Debian 12 packages
# installed by .ci/bootstrap.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(tomlplusplus REQUIRED)
find_package(CLI11 REQUIRED)
find_package(Boost 1.74 REQUIRED COMPONENTS system)
find_package(SQLite3 REQUIRED)
find_package(OpenSSL REQUIRED)  # TLS listeners and gonioctl; SHA-256 and constant-time compare of bearer tokens
pkg_check_modules(MODBUS REQUIRED IMPORTED_TARGET libmodbus)
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
pkg_check_modules(SYSTEMD REQUIRED IMPORTED_TARGET libsystemd)
pkg_check_modules(MOSQUITTO REQUIRED IMPORTED_TARGET libmosquitto)
pkg_check_modules(PQ REQUIRED IMPORTED_TARGET libpq)
pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo)
# Levenberg–Marquardt of the inverse twin (gonio-twin fit / calibrate): Eigen's unsupported
# LevenbergMarquardt module, header-only.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)

if(GONIO_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(GONIO_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()

# CIE tables come from colord-data (docs/architecture.md §2); the path is baked in as the default.
set(GONIO_COLORD_DIR "/usr/share/colord" CACHE PATH "colord-data directory with cmf/ and illuminant/")
