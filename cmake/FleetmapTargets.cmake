# Helpers shared by every folder: one warning set, one way to declare a library and a test.
include(GNUInstallDirs)

set(FLEETMAP_WARNINGS -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
                      -Wcast-align -Wunused -Woverloaded-virtual)

# Precompiled headers: the third-party and standard headers nearly every unit parses
# (Eigen through graph.h and se3.h in 197 of 278 units, the standard library; GoogleTest in every
# test) are compiled once into a header of each donor below, which every library, program and
# test reuses (REUSE_FROM). Only third-party and standard headers, never a fleetmap/ one, so a
# unit still includes all it uses and scripts/check-layering still sees every include.
# -DFLEETMAP_PCH=OFF builds without them (to check that each file includes what it uses).
option(FLEETMAP_PCH "Precompile the heavy third-party headers once, for every target" ON)
set(FLEETMAP_PCH_STD_HEADERS <algorithm> <chrono> <cstdint> <filesystem> <functional> <map>
                             <memory> <optional> <set> <span> <string> <string_view>
                             <unordered_map> <unordered_set> <utility> <vector>)

# The test binaries whose cases drive built programs in subprocesses (fleetmap_test's
# DRIVES_PROCESSES: fleetmapd, fleetmap-agent, fleetmap) are compiled without optimisation:
# code generation at -O2 was two thirds of their compile time, and what they measure
# runs in the programs, built -O2 as ever. Not for binaries that run library code in-process:
# the linker keeps the first copy of an inline function it meets, the test's unoptimised one,
# and the library would run it (the fleet experiment's test took 1.5x as long).
set(FLEETMAP_PROCESS_TEST_OPTIONS -O0)

# fleetmap_define_pch_donors(): the donors, after find_package of Eigen and GoogleTest.
function(fleetmap_define_pch_donors)
  if(NOT FLEETMAP_PCH OR FLEETMAP_FUZZ)
    return()
  endif()
  file(WRITE ${CMAKE_BINARY_DIR}/fleetmap_pch_donor.cc "// the precompiled headers' donor\n")
  add_library(fleetmap_pch OBJECT ${CMAKE_BINARY_DIR}/fleetmap_pch_donor.cc)
  target_link_libraries(fleetmap_pch PRIVATE Eigen3::Eigen)
  target_compile_options(fleetmap_pch PRIVATE ${FLEETMAP_WARNINGS})
  target_precompile_headers(fleetmap_pch PRIVATE ${FLEETMAP_PCH_STD_HEADERS} <Eigen/Core>
                            <Eigen/Geometry>)
  # Tests: one donor for optimised binaries, one for the unoptimised ones (fleetmap_test's
  # DRIVES_PROCESSES): GCC uses a precompiled header only under the options it was made with.
  foreach(donor fleetmap_test_pch fleetmap_process_test_pch)
    add_library(${donor} OBJECT ${CMAKE_BINARY_DIR}/fleetmap_pch_donor.cc)
    target_link_libraries(${donor} PRIVATE Eigen3::Eigen GTest::gtest
                          nlohmann_json::nlohmann_json)
    target_compile_options(${donor} PRIVATE ${FLEETMAP_WARNINGS})
    target_precompile_headers(${donor} PRIVATE ${FLEETMAP_PCH_STD_HEADERS} <Eigen/Core>
                              <Eigen/Geometry> <gtest/gtest.h> <nlohmann/json.hpp>)
  endforeach()
  target_compile_options(fleetmap_process_test_pch PRIVATE ${FLEETMAP_PROCESS_TEST_OPTIONS})
endfunction()

# fleetmap_use_pch(TARGET [TEST|PROCESS_TEST]): TARGET reuses the donor's precompiled headers.
function(fleetmap_use_pch target)
  set(donor fleetmap_pch)
  if(ARGV1 STREQUAL "TEST")
    set(donor fleetmap_test_pch)
  elseif(ARGV1 STREQUAL "PROCESS_TEST")
    set(donor fleetmap_process_test_pch)
  endif()
  if(TARGET ${donor})
    target_precompile_headers(${target} REUSE_FROM ${donor})
  endif()
endfunction()

# fleetmap_library(NAME SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...): a library with public
# headers in include/ and private implementation in src/ (LevelDB's split). NAME is
# fleetmap_<concern>; the library is also fleetmap::<concern>, the name another project links
# after find_package(fleetmap). The deps are what the library may include: scripts/check-layering
# fails when its sources include a header of a library not listed here.
function(fleetmap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} ${ARG_SOURCES})
  string(REGEX REPLACE "^fleetmap_" "" concern ${name})
  add_library(fleetmap::${concern} ALIAS ${name})
  set_target_properties(${name} PROPERTIES EXPORT_NAME ${concern})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                            $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
                                     PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_options(${name} PRIVATE ${FLEETMAP_WARNINGS})
  if(NOT name STREQUAL "fleetmap_proto")
    fleetmap_use_pch(${name})
  endif()
  # The public headers are C++20 (operator<=>, std::span): said on the interface, so a project
  # that links an installed fleetmap library needs no CMAKE_CXX_STANDARD of its own.
  target_compile_features(${name} INTERFACE cxx_std_20)
  set_property(GLOBAL APPEND PROPERTY FLEETMAP_LIBRARIES ${name})
  string(REPLACE ";" " " public_deps "${ARG_PUBLIC_DEPS}")
  string(REPLACE ";" " " private_deps "${ARG_PRIVATE_DEPS}")
  set_property(GLOBAL APPEND PROPERTY FLEETMAP_LAYERING
    "${name}|${CMAKE_CURRENT_SOURCE_DIR}|${public_deps}|${private_deps}")
endfunction()

# fleetmap_warnings(TARGET): the project warning set on an executable.
# Programs also reuse the precompiled headers.
function(fleetmap_warnings target)
  target_compile_options(${target} PRIVATE ${FLEETMAP_WARNINGS})
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "EXECUTABLE")
    fleetmap_use_pch(${target} ${ARGV1})
  endif()
endfunction()

# fleetmap_embed_sql(OUT VAR DIR): turns the numbered migration files DIR/NNNN_*.sql into a
# generated C++ source defining `const std::vector<Migration>& VAR()`, so the binary carries
# its schema and can refuse a database newer than itself.
function(fleetmap_embed_sql out_var func_name dir)
  file(GLOB files CONFIGURE_DEPENDS ${dir}/[0-9][0-9][0-9][0-9]_*.sql)
  list(SORT files)
  # The SQL is read here, at configure time: an edited migration must re-run the configure.
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${files})
  set(body "")
  foreach(f ${files})
    get_filename_component(fname ${f} NAME)
    string(SUBSTRING ${fname} 0 4 num)
    math(EXPR num "${num} + 0")
    file(READ ${f} sql)
    string(APPEND body "      {${num}, \"${fname}\", R\"fleetmap_sql(${sql})fleetmap_sql\"},\n")
  endforeach()
  set(gen ${CMAKE_CURRENT_BINARY_DIR}/${func_name}.cc)
  file(WRITE ${gen}.tmp
"// Generated by cmake/FleetmapTargets.cmake from ${dir}; do not edit.
#include \"migration.h\"

namespace fleetmap::internal {
const std::vector<Migration>& ${func_name}() {
  static const std::vector<Migration> migrations = {
${body}  };
  return migrations;
}
}  // namespace fleetmap::internal
")
  configure_file(${gen}.tmp ${gen} COPYONLY)
  set(${out_var} ${gen} PARENT_SCOPE)
endfunction()

# Writes build/fleetmap-layering.txt once every library is declared: one line per library,
# NAME|SOURCE_DIR|PUBLIC DEPS|PRIVATE DEPS, which scripts/check-layering reads to compare each
# library's includes with what it links.
function(fleetmap_write_layering)
  get_property(lines GLOBAL PROPERTY FLEETMAP_LAYERING)
  string(REPLACE ";" "\n" text "${lines}")
  file(WRITE ${CMAKE_BINARY_DIR}/fleetmap-layering.txt.tmp "${text}\n")
  configure_file(${CMAKE_BINARY_DIR}/fleetmap-layering.txt.tmp
                 ${CMAKE_BINARY_DIR}/fleetmap-layering.txt COPYONLY)
endfunction()
cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL fleetmap_write_layering)
