# fleetmap_ros_test_bag: ROS's own bag writer (librosbag-storage) and message types
# (sensor_msgs), which the ROS bag tests write their bags with (tests/support/ros_test_bag.h, .cc),
# so fleetmap's own reader (common/rosbag) is checked against the reference implementation.
# Tests only: fleetmap never links it (common/rosbag/include/fleetmap/rosbag/bag_reader.h says
# why). Found directly, because its pkg-config file requires a pluginlib.pc that no Debian
# package ships and its CMake config runs ament's Python: neither works outside a ROS workspace.
# Its headers are SYSTEM includes: they are not held to fleetmap's warnings.
set(_fleetmap_ros_missing "")
foreach(header rosbag/bag.h sensor_msgs/Image.h pluginlib/class_loader.hpp
               class_loader/class_loader.hpp rcutils/types.h rcpputils/filesystem_helper.hpp
               ament_index_cpp/get_package_prefix.hpp)
  string(MAKE_C_IDENTIFIER "FLEETMAP_ROS_${header}" var)
  get_filename_component(package ${header} DIRECTORY)
  # ROS 2's packages (pluginlib, class_loader, ...) put their headers one level deeper.
  find_path(${var} ${header} PATH_SUFFIXES ${package})
  if(${var})
    list(APPEND _fleetmap_ros_include_dirs ${${var}})
  else()
    list(APPEND _fleetmap_ros_missing ${header})
  endif()
endforeach()
foreach(lib rosbag_storage roscpp_serialization rostime cpp_common console_bridge
            boost_filesystem)
  find_library(FLEETMAP_ROS_LIB_${lib} ${lib})
  if(FLEETMAP_ROS_LIB_${lib})
    list(APPEND _fleetmap_ros_libraries ${FLEETMAP_ROS_LIB_${lib}})
  else()
    list(APPEND _fleetmap_ros_missing lib${lib})
  endif()
endforeach()
if(_fleetmap_ros_missing)
  message(FATAL_ERROR "The ROS bag tests write bags with ROS's own writer; not found: "
                      "${_fleetmap_ros_missing}. Install librosbag-storage-dev and "
                      "libsensor-msgs-dev (scripts/setup does).")
endif()
list(REMOVE_DUPLICATES _fleetmap_ros_include_dirs)
# Never the system include directory itself: -isystem /usr/include breaks libstdc++'s
# #include_next.
list(REMOVE_ITEM _fleetmap_ros_include_dirs /usr/include)
# C++17: ROS's generated message headers use std::allocator<void>::rebind, gone in C++20. So it
# does not link fleetmap_rosbag (whose interface asks for C++20) but only sees the plain structs
# of its sensor_msgs.h; the tests link the library.
fleetmap_find_opencv(core)
add_library(fleetmap_ros_test_bag STATIC ${PROJECT_SOURCE_DIR}/tests/support/ros_test_bag.cc)
set_target_properties(fleetmap_ros_test_bag PROPERTIES CXX_STANDARD 17)
target_include_directories(fleetmap_ros_test_bag SYSTEM PRIVATE ${_fleetmap_ros_include_dirs})
target_include_directories(fleetmap_ros_test_bag PUBLIC ${PROJECT_SOURCE_DIR}/tests/support
                                                        ${PROJECT_SOURCE_DIR}/common/rosbag/include)
target_link_libraries(fleetmap_ros_test_bag PUBLIC ${OpenCV_LIBS}
                                            PRIVATE ${_fleetmap_ros_libraries})
fleetmap_warnings(fleetmap_ros_test_bag)
