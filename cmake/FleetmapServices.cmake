# `cmake --install`: the programs as system services (docs/operations.md, "Run as services"):
# systemd units for fleetmapd and `fleetmap-agent daemon`, their example config files, the
# sysusers.d entry of the user they run as, and the documentation the units name. Included by
# the top-level CMakeLists.txt after FleetmapInstall.cmake; everything here is in the install
# component `runtime`, which is also what the Debian package holds (FleetmapDebianPackage.cmake).
#
# The units name the programs and config files by absolute path, so they are written at
# install time for the prefix of that install (`cmake --install build --prefix /opt/fleetmap`,
# or /usr inside the Debian package), not the one configured. Config files go to /etc when the
# prefix is /usr (the Debian layout) and to PREFIX/etc otherwise; an existing config file is
# left as it is, since it holds a site's settings (the Debian package's are conffiles).
include(GNUInstallDirs)

# systemd looks for units in /usr/lib/systemd/system and /usr/local/lib/systemd/system.
set(FLEETMAP_SYSTEMD_UNIT_DIR "lib/systemd/system" CACHE STRING
    "Where cmake --install puts the systemd units (relative: to the prefix)")
set(FLEETMAP_SYSUSERS_DIR "lib/sysusers.d" CACHE STRING
    "Where cmake --install puts the sysusers.d entry (relative: to the prefix)")

set(fleetmap_packaging_dir ${PROJECT_SOURCE_DIR}/packaging)
if(IS_ABSOLUTE "${FLEETMAP_SYSTEMD_UNIT_DIR}")
  set(fleetmap_unit_destination "${FLEETMAP_SYSTEMD_UNIT_DIR}")
else()
  set(fleetmap_unit_destination "\${CMAKE_INSTALL_PREFIX}/${FLEETMAP_SYSTEMD_UNIT_DIR}")
endif()
install(FILES ${fleetmap_packaging_dir}/sysusers/fleetmap.conf
        DESTINATION ${FLEETMAP_SYSUSERS_DIR} COMPONENT runtime)
install(FILES ${PROJECT_SOURCE_DIR}/README.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs COMPONENT runtime FILES_MATCHING PATTERN "*.md")

# Runs inside cmake_install.cmake, where CMAKE_INSTALL_PREFIX is the prefix being installed to
# and file(INSTALL) puts DESTDIR (CPack's staging directory) in front of absolute paths.
install(CODE "
  set(fleetmap_prefix \"\${CMAKE_INSTALL_PREFIX}\")
  if(fleetmap_prefix STREQUAL \"/usr\")
    set(FLEETMAP_SYSCONFDIR \"/etc\")
  else()
    set(FLEETMAP_SYSCONFDIR \"\${fleetmap_prefix}/etc\")
  endif()
  set(FLEETMAP_BINDIR \"\${fleetmap_prefix}/${CMAKE_INSTALL_BINDIR}\")
  set(FLEETMAP_DOCDIR \"\${fleetmap_prefix}/${CMAKE_INSTALL_DOCDIR}\")
  # One folder per destination: an install and a package may be made at the same time.
  string(MAKE_C_IDENTIFIER \"\$ENV{DESTDIR}\${fleetmap_prefix}\" fleetmap_destination)
  set(fleetmap_units \"${PROJECT_BINARY_DIR}/packaging/systemd/\${fleetmap_destination}\")
  foreach(unit fleetmapd fleetmap-agent)
    configure_file(\"${fleetmap_packaging_dir}/systemd/\${unit}.service.in\"
                   \"\${fleetmap_units}/\${unit}.service\" @ONLY)
    file(INSTALL \"\${fleetmap_units}/\${unit}.service\"
         DESTINATION \"${fleetmap_unit_destination}\")
  endforeach()
  foreach(config fleetmapd.toml agent.toml)
    if(EXISTS \"\$ENV{DESTDIR}\${FLEETMAP_SYSCONFDIR}/fleetmap/\${config}\")
      message(STATUS \"Keeping: \$ENV{DESTDIR}\${FLEETMAP_SYSCONFDIR}/fleetmap/\${config}\")
    else()
      file(INSTALL \"${fleetmap_packaging_dir}/config/\${config}\"
           DESTINATION \"\${FLEETMAP_SYSCONFDIR}/fleetmap\")
    endif()
  endforeach()
" COMPONENT runtime)
