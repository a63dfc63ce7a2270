# A Debian package of everything `cmake --install` installs:
#   cpack --config build/release/CPackConfig.cmake
# writes build/release/packages/gonio_<version>_<arch>.deb. Library dependencies come from
# dpkg-shlibdeps; the maintainer scripts in systemd/debian/ create the gonio account and
# directories and reload systemd and udev.

# The unit and tmpfiles.d name absolute paths under the configured prefix, so the package
# uses that prefix too (CPack's DEB default is /usr whatever the build was configured for).
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
if(NOT CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  message(STATUS "gonio: the Debian package wants CMAKE_INSTALL_PREFIX=/usr (the presets set it; "
                 "it is ${CMAKE_INSTALL_PREFIX})")
endif()

set(GONIO_PACKAGE_MAINTAINER "gonio maintainers <gonio@invalid>" CACHE STRING
    "Maintainer field of the Debian package")

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME gonio)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "goniometric spectrophotometer service with a digital twin")
string(CONCAT CPACK_PACKAGE_DESCRIPTION
    "goniod runs a goniometric spectrophotometer (first profile: the Murakami\n"
    "GCMS-4): it drives the arms over Modbus and the photometer over SCPI,\n"
    "schedules scans over JSON-RPC and predicts every measured point with a\n"
    "Monte Carlo model of the instrument, raising alerts when measurement and\n"
    "prediction disagree. With gonioctl (the client), gonio-twin (the model as a\n"
    "tool) and gonio-probe (device commissioning).")
set(CPACK_STRIP_FILES ON)

set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER ${GONIO_PACKAGE_MAINTAINER})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# systemd: sysusers and tmpfiles in postinst; colord-data: the CIE tables of the twin's
# colorimetry (read at run time); the plots ask fontconfig for DejaVu Sans.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd, colord-data")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "udev, fonts-dejavu-core")

# /etc/gonio/goniod.toml is edited on every installation: a conffile that upgrades keep.
file(CONFIGURE OUTPUT ${PROJECT_BINARY_DIR}/deploy/debian/conffiles
     CONTENT "${GONIO_CONFDIR}/goniod.toml\n")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_BINARY_DIR}/deploy/debian/conffiles
    ${PROJECT_SOURCE_DIR}/systemd/debian/postinst
    ${PROJECT_SOURCE_DIR}/systemd/debian/prerm
    ${PROJECT_SOURCE_DIR}/systemd/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

include(CPack)
