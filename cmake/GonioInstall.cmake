# Installation on the instrument PC, in the Debian layout (the presets set the prefix to
# /usr). Each module installs its programs; this file adds the service around them: the
# systemd unit, udev rules, sysusers.d, tmpfiles.d and modules-load.d files, the
# configuration /etc/gonio/goniod.toml (daemon/examples/goniod-hardware.toml), the OpenRPC
# document, the man pages and the documentation.

set(GONIO_SYSTEMD_UNITDIR "lib/systemd/system" CACHE STRING "systemd system units, relative to the prefix")
set(GONIO_UDEV_RULESDIR "lib/udev/rules.d" CACHE STRING "udev rules, relative to the prefix")
set(GONIO_SYSUSERSDIR "lib/sysusers.d" CACHE STRING "sysusers.d files, relative to the prefix")
set(GONIO_TMPFILESDIR "lib/tmpfiles.d" CACHE STRING "tmpfiles.d files, relative to the prefix")
set(GONIO_MODULESLOADDIR "lib/modules-load.d" CACHE STRING "modules-load.d files, relative to the prefix")
# /etc/gonio for the prefixes /usr and /, <prefix>/etc/gonio otherwise (GNUInstallDirs).
set(GONIO_CONFDIR "${CMAKE_INSTALL_FULL_SYSCONFDIR}/gonio")

set(gonio_deploy_dir ${PROJECT_BINARY_DIR}/deploy)
set(gonio_systemd_dir ${PROJECT_SOURCE_DIR}/systemd)

# The unit and the tmpfiles.d file name goniod and its configuration by absolute path, as
# installed with the prefix /usr; other prefixes get copies that point at theirs.
function(gonio_deploy_file src out)
  file(READ ${src} text)
  string(REPLACE "/usr/bin/" "${CMAKE_INSTALL_FULL_BINDIR}/" text "${text}")
  string(REPLACE "/etc/gonio" "${GONIO_CONFDIR}" text "${text}")
  file(GENERATE OUTPUT ${out} CONTENT "${text}")
  set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${src})
endfunction()
gonio_deploy_file(${gonio_systemd_dir}/goniod.service ${gonio_deploy_dir}/goniod.service)
gonio_deploy_file(${gonio_systemd_dir}/tmpfiles.d/gonio.conf ${gonio_deploy_dir}/tmpfiles.conf)
gonio_deploy_file(${gonio_systemd_dir}/gonio-backup.service ${gonio_deploy_dir}/gonio-backup.service)

install(FILES ${gonio_deploy_dir}/goniod.service ${gonio_deploy_dir}/gonio-backup.service
              ${gonio_systemd_dir}/gonio-backup.timer
        DESTINATION ${GONIO_SYSTEMD_UNITDIR})
install(FILES ${gonio_systemd_dir}/70-gonio.rules DESTINATION ${GONIO_UDEV_RULESDIR})
install(FILES ${gonio_systemd_dir}/sysusers.d/gonio.conf DESTINATION ${GONIO_SYSUSERSDIR})
install(FILES ${gonio_deploy_dir}/tmpfiles.conf DESTINATION ${GONIO_TMPFILESDIR} RENAME gonio.conf)
install(FILES ${gonio_systemd_dir}/modules-load.d/gonio.conf DESTINATION ${GONIO_MODULESLOADDIR})
install(FILES ${PROJECT_SOURCE_DIR}/daemon/examples/goniod-hardware.toml
        DESTINATION ${GONIO_CONFDIR} RENAME goniod.toml)
install(FILES ${PROJECT_SOURCE_DIR}/proto/openrpc.json DESTINATION ${CMAKE_INSTALL_DATADIR}/gonio)

# Man pages, compressed as Debian ships them (gzip -9n: no name or time stamp inside).
find_program(GONIO_GZIP gzip REQUIRED)
set(GONIO_MAN_PAGES
  daemon/man/goniod.8 daemon/man/gonioctl.1 twin/man/gonio-twin.1 drivers/man/gonio-probe.1)
set(gonio_man_gz)
foreach(page ${GONIO_MAN_PAGES})
  get_filename_component(name ${page} NAME)
  string(REGEX REPLACE "^.*\\.([1-8])$" "\\1" section ${name})
  set(gz ${gonio_deploy_dir}/man/${name}.gz)
  add_custom_command(OUTPUT ${gz}
    COMMAND ${GONIO_GZIP} -9nc ${PROJECT_SOURCE_DIR}/${page} > ${gz}
    DEPENDS ${PROJECT_SOURCE_DIR}/${page}
    COMMENT "Compressing ${name}")
  install(FILES ${gz} DESTINATION ${CMAKE_INSTALL_MANDIR}/man${section})
  list(APPEND gonio_man_gz ${gz})
endforeach()
file(MAKE_DIRECTORY ${gonio_deploy_dir}/man)
add_custom_target(gonio_man ALL DEPENDS ${gonio_man_gz})

# Documentation the man pages refer to, and both example configurations.
install(FILES ${PROJECT_SOURCE_DIR}/README.md
              ${PROJECT_SOURCE_DIR}/twin/bsdf_spec.md
              ${PROJECT_SOURCE_DIR}/twin/bsdf_formats.md
              ${PROJECT_SOURCE_DIR}/twin/colorimetry.md
              ${PROJECT_SOURCE_DIR}/proto/scpi-gonio.md
              ${PROJECT_SOURCE_DIR}/proto/errors.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/daemon/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME daemon.md)
install(FILES ${PROJECT_SOURCE_DIR}/drivers/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME drivers.md)
install(FILES ${PROJECT_SOURCE_DIR}/daemon/examples/goniod-hardware.toml
              ${PROJECT_SOURCE_DIR}/daemon/examples/goniod-mock.toml
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)
