# `cmake --install build --prefix PREFIX`: the `fleetmap` CLI, the fleetmapd and fleetmap-agent
# daemons, every library with its public headers (the generated protobuf headers too), and a
# CMake package, so that another project can write
#   find_package(fleetmap REQUIRED)
#   target_link_libraries(app PRIVATE fleetmap::store)
# Included by the top-level CMakeLists.txt after every add_subdirectory: it reads the GLOBAL
# property FLEETMAP_LIBRARIES, which each fleetmap_library() call appends to.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(FLEETMAP_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/fleetmap)
get_property(fleetmap_libraries GLOBAL PROPERTY FLEETMAP_LIBRARIES)

# Public headers: each library's include/ holds only include/fleetmap/<concern>/, so they merge
# into one tree, the one the libraries' $<INSTALL_INTERFACE:...> names (fleetmap_library).
foreach(lib IN LISTS fleetmap_libraries)
  get_target_property(lib_source_dir ${lib} SOURCE_DIR)
  if(IS_DIRECTORY ${lib_source_dir}/include)
    install(DIRECTORY ${lib_source_dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endforeach()
get_target_property(fleetmap_proto_headers fleetmap_proto FLEETMAP_GENERATED_HEADERS)
install(FILES ${fleetmap_proto_headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/fleetmap)

set(fleetmap_exported fleetmap_proto ${fleetmap_libraries})
install(TARGETS ${fleetmap_exported} EXPORT fleetmapTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
# The programs are the install component `runtime`, with the services (FleetmapServices.cmake):
# what the Debian package holds.
install(TARGETS fleetmap fleetmapd fleetmap-agent RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        COMPONENT runtime)
install(EXPORT fleetmapTargets NAMESPACE fleetmap:: DESTINATION ${FLEETMAP_INSTALL_CMAKEDIR})

# The targets the exported libraries link that are not fleetmap's own (protobuf::libprotobuf,
# PkgConfig::UUID, the OpenCV modules, ...). The libraries are static, so even PRIVATE deps
# are exported, as $<LINK_ONLY:...>. fleetmapConfig.cmake checks that its find_dependency
# calls made every one of them: a name that is not a target would otherwise reach the linker
# as -lNAME and fail far from its cause.
set(FLEETMAP_DEPENDENCY_TARGETS "")
foreach(lib IN LISTS fleetmap_exported)
  foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
    get_target_property(deps ${lib} ${property})
    foreach(dep IN LISTS deps)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
      # Skipped: the directory markers target_link_libraries adds when called from another
      # folder (::@...), and fleetmap's own libraries (exported alongside).
      if(dep MATCHES "^::@" OR dep IN_LIST fleetmap_exported OR dep MATCHES "^fleetmap::")
        continue()
      endif()
      if(dep MATCHES "\\$<")
        message(FATAL_ERROR "${lib} links ${dep}: a generator expression fleetmapConfig.cmake "
                            "cannot check; teach cmake/FleetmapInstall.cmake about it")
      endif()
      list(APPEND FLEETMAP_DEPENDENCY_TARGETS ${dep})
    endforeach()
  endforeach()
endforeach()
list(REMOVE_DUPLICATES FLEETMAP_DEPENDENCY_TARGETS)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/fleetmapConfig.cmake.in
  ${PROJECT_BINARY_DIR}/fleetmapConfig.cmake INSTALL_DESTINATION ${FLEETMAP_INSTALL_CMAKEDIR})
# 0.x: a minor version may break the API, so only the same major.minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/fleetmapConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/fleetmapConfig.cmake
              ${PROJECT_BINARY_DIR}/fleetmapConfigVersion.cmake
              ${CMAKE_CURRENT_LIST_DIR}/FleetmapOpenCV.cmake
        DESTINATION ${FLEETMAP_INSTALL_CMAKEDIR})
