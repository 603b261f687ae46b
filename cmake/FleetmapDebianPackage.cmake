# `cpack -G DEB` (in the build directory, after the build): a Debian package `fleetmap` of the
# install component `runtime`: the three programs (stripped), the systemd units, the example
# config files in /etc/fleetmap (conffiles), the sysusers.d entry, README.md and docs/. Its
# postinst makes the user `fleetmap` and enables nothing (packaging/debian/). The libraries,
# headers and CMake package are for `cmake --install` (docs/operations.md, "Using fleetmap from
# another project").
#
# Depends comes from dpkg-shlibdeps (dpkg-dev) over the programs' shared libraries, plus what
# the postinst needs; tests/install/debian_package_test.sh checks that every library the
# programs load comes from a package it names.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME fleetmap)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "fleetmap")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "version control for the visual experience maps of a robot fleet")
set(FLEETMAP_PACKAGE_MAINTAINER "fleetmap maintainers <fleetmap@example.org>" CACHE STRING
    "Maintainer field of the Debian package (cpack -G DEB)")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${FLEETMAP_PACKAGE_MAINTAINER}")
# The summary is the synopsis line; this is the extended description under it.
string(CONCAT CPACK_DEBIAN_PACKAGE_DESCRIPTION
  "Robots push the experience maps they build (Experience-Based Navigation) to a central\n"
  "repository when they dock; the repository merges them into linear revisions and hands\n"
  "each robot the part of the map its next mission needs. This package holds the fleetmap\n"
  "command-line tool, the fleetmapd repository daemon and the fleetmap-agent robot daemon,\n"
  "with systemd units for both daemons and example configuration in /etc/fleetmap.")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The postinst makes the user with systemd-sysusers, or adduser where there is no systemd.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd | adduser")
# conffiles: dpkg keeps a site's edits of the config files across upgrades.
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/packaging/debian/postinst
    ${PROJECT_SOURCE_DIR}/packaging/debian/postrm ${PROJECT_SOURCE_DIR}/packaging/debian/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_STRIP_FILES ON)

# Installed with prefix /usr into DESTDIR, so the units name /usr/bin and the config files land
# in /etc (FleetmapServices.cmake decides both at install time).
set(CPACK_SET_DESTDIR ON)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime)
set(CPACK_COMPONENTS_GROUPING ALL_COMPONENTS_IN_ONE)

include(CPack)
