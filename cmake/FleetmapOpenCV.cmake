# fleetmap_find_opencv(MODULE...): sets OpenCV_LIBS (targets to link) for the listed OpenCV
# modules, e.g. fleetmap_find_opencv(core features2d).
#
# Why not only find_package(OpenCV): scripts/setup installs just the module packages
# (libopencv-core-dev, ...), and on Debian the CMake package config and opencv4.pc ship only
# with the 230-package libopencv-dev. Where the config exists it is used; otherwise the
# headers and module libraries are found directly.
macro(fleetmap_find_opencv)
  find_package(OpenCV QUIET CONFIG COMPONENTS ${ARGN})
  if(NOT OpenCV_FOUND)
    find_path(FLEETMAP_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
    set(OpenCV_LIBS "")
    foreach(_fleetmap_cv_module ${ARGN})
      set(_fleetmap_cv_target fleetmap_opencv_${_fleetmap_cv_module})
      if(NOT TARGET ${_fleetmap_cv_target})
        find_library(FLEETMAP_OPENCV_${_fleetmap_cv_module}_LIBRARY
                     opencv_${_fleetmap_cv_module} REQUIRED)
        add_library(${_fleetmap_cv_target} UNKNOWN IMPORTED GLOBAL)
        set_target_properties(${_fleetmap_cv_target} PROPERTIES
          IMPORTED_LOCATION ${FLEETMAP_OPENCV_${_fleetmap_cv_module}_LIBRARY}
          INTERFACE_INCLUDE_DIRECTORIES ${FLEETMAP_OPENCV_INCLUDE_DIR})
      endif()
      list(APPEND OpenCV_LIBS ${_fleetmap_cv_target})
    endforeach()
    message(STATUS "OpenCV (module libraries, no package config): ${ARGN}")
  endif()
endmacro()
