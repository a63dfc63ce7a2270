# A Debian package of everything `cmake --install` installs:
#   cpack --config build/release/CPackConfig.cmake
# writes build/release/packages/gonio_<version>_<arch>.deb, a native package (the version has
# no Debian revision). Library dependencies come from dpkg-shlibdeps; the maintainer scripts
# in systemd/debian/ create the gonio account and directories, handle goniod.service through
# deb-systemd-helper / deb-systemd-invoke and reload udev. tests/deploy/debian_package.sh
# holds the package to lintian.

# The unit and tmpfiles.d name absolute paths under the configured prefix, so the package
# uses that prefix too (CPack's DEB default is /usr whatever the build was configured for).
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
if(NOT CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  message(STATUS "gonio: the Debian package wants CMAKE_INSTALL_PREFIX=/usr (the presets set it; "
                 "it is ${CMAKE_INSTALL_PREFIX})")
endif()

# Debian policy §5.6.2: "NAME <ADDRESS>". Whoever builds packages for a site sets their own;
# the default's domain is reserved for examples (RFC 2606) but is a domain, as lintian wants.
set(GONIO_PACKAGE_MAINTAINER "gonio maintainers <gonio@example.org>" CACHE STRING
    "Maintainer field of the Debian package and its changelog: NAME <USER@DOMAIN>")
# Build trees configured before kept the earlier default, which lintian refuses.
if(GONIO_PACKAGE_MAINTAINER STREQUAL "gonio maintainers <gonio@invalid>")
  set(GONIO_PACKAGE_MAINTAINER "gonio maintainers <gonio@example.org>" CACHE STRING
      "Maintainer field of the Debian package and its changelog: NAME <USER@DOMAIN>" FORCE)
endif()
if(NOT GONIO_PACKAGE_MAINTAINER MATCHES "^[^<>@]*[^<>@ ] <[^<>@ ]+@[A-Za-z0-9-]+(\\.[A-Za-z0-9-]+)+>$")
  message(FATAL_ERROR "GONIO_PACKAGE_MAINTAINER is '${GONIO_PACKAGE_MAINTAINER}': expected "
                      "'NAME <USER@DOMAIN>' with a dotted domain, e.g. 'Lab IT <it@lab.example.org>'")
endif()

# The two files policy wants in every package's /usr/share/doc (§12.5, §12.7): copyright, in
# the machine-readable format, and the changelog of a native package, changelog.gz. The
# changelog is one entry for the project version by the maintainer above, dated by
# SOURCE_DATE_EPOCH when set, else by the last commit, so that a commit always gives the
# same file; only a tree without git history takes the time of configuration.
set(gonio_changelog_epoch "$ENV{SOURCE_DATE_EPOCH}")
if(gonio_changelog_epoch STREQUAL "")
  find_package(Git QUIET)
  if(GIT_FOUND)
    execute_process(COMMAND ${GIT_EXECUTABLE} log -1 --format=%ct
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE gonio_changelog_epoch OUTPUT_STRIP_TRAILING_WHITESPACE
                    RESULT_VARIABLE gonio_git_rc ERROR_QUIET)
    if(NOT gonio_git_rc EQUAL 0)
      set(gonio_changelog_epoch "")
    endif()
  endif()
endif()
set(gonio_saved_epoch "$ENV{SOURCE_DATE_EPOCH}")
set(ENV{SOURCE_DATE_EPOCH} "${gonio_changelog_epoch}")  # string(TIMESTAMP) reads it
string(TIMESTAMP gonio_changelog_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
set(ENV{SOURCE_DATE_EPOCH} "${gonio_saved_epoch}")
file(CONFIGURE OUTPUT ${PROJECT_BINARY_DIR}/deploy/debian/changelog CONTENT "\
gonio (${PROJECT_VERSION}) unstable; urgency=medium

  * gonio ${PROJECT_VERSION}: goniod, gonioctl, gonio-twin and gonio-probe as built
    from the project's sources of that version.

 -- ${GONIO_PACKAGE_MAINTAINER}  ${gonio_changelog_date}
")
add_custom_command(OUTPUT ${PROJECT_BINARY_DIR}/deploy/debian/changelog.gz
  COMMAND ${GONIO_GZIP} -9nc ${PROJECT_BINARY_DIR}/deploy/debian/changelog
          > ${PROJECT_BINARY_DIR}/deploy/debian/changelog.gz
  DEPENDS ${PROJECT_BINARY_DIR}/deploy/debian/changelog
  COMMENT "Compressing the Debian changelog")
add_custom_target(gonio_changelog ALL DEPENDS ${PROJECT_BINARY_DIR}/deploy/debian/changelog.gz)
install(FILES ${PROJECT_BINARY_DIR}/deploy/debian/changelog.gz
              ${PROJECT_SOURCE_DIR}/systemd/debian/copyright
        DESTINATION ${CMAKE_INSTALL_DOCDIR})

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
# (deb-systemd-helper and deb-systemd-invoke come with init-system-helpers, an essential
# package: not named.)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd, colord-data")
# openssl: the postinst's self-signed certificate for the TLS listeners.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "udev, fonts-dejavu-core, openssl")

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
