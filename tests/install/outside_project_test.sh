#!/usr/bin/env bash
# Installs the finished build into a temporary prefix and builds a project outside the tree
# against it (outside/: find_package(fleetmap), links fleetmap::store), then runs that program
# and the installed executables. Proves that `cmake --install` gives another project everything
# it needs, with no path back into the source or build tree.
#
# usage: outside_project_test.sh BUILD_DIR SOURCE_DIR WORK_PARENT CMAKE NINJA CXX BUILD_TYPE
# (tests/install/CMakeLists.txt passes these). REQUIRES: BUILD_DIR fully built (ctest runs after
# the build; `cmake --install` builds nothing).
set -euo pipefail

if [ $# -ne 7 ]; then
  echo "usage: $0 BUILD_DIR SOURCE_DIR WORK_PARENT CMAKE NINJA CXX BUILD_TYPE" >&2
  exit 2
fi
build_dir=$1 source_dir=$2 work_parent=$3 cmake=$4 ninja=$5 cxx=$6 build_type=$7

source "$(dirname "$0")/install_test_steps.sh"
install_test_start "$work_parent" outside_project
prefix=$work/prefix

run "cmake --install $build_dir --prefix <tmp>" "$cmake" --install "$build_dir" --prefix "$prefix"

step="check the installed files"
echo "== $step"
for file in bin/fleetmap bin/fleetmapd bin/fleetmap-agent; do
  [ -x "$prefix/$file" ] || { echo "not installed: $file" >&2; exit 1; }
done
package_dir=$(dirname "$(find "$prefix" -path '*/cmake/fleetmap/fleetmapConfig.cmake' | head -n 1)")
for file in include/fleetmap/store/graph_store.h include/fleetmap/core/uuid.h \
            include/fleetmap/map.pb.h include/fleetmap/sync.pb.h; do
  [ -f "$prefix/$file" ] || { echo "not installed: $file" >&2; exit 1; }
done
for file in fleetmapConfig.cmake fleetmapConfigVersion.cmake fleetmapTargets.cmake \
            FleetmapOpenCV.cmake; do
  [ -f "$package_dir/$file" ] || { echo "not installed: $package_dir/$file" >&2; exit 1; }
done
# The package must stand on its own: a path into the checkout or the build would work here and
# break on any other machine.
if grep -n -F -e "$source_dir" -e "$build_dir" "$package_dir"/*.cmake; then
  echo "the installed package names the source or build tree (above)" >&2
  exit 1
fi
echo "   $(find "$prefix" -type f | wc -l) files; package in ${package_dir#"$prefix"/}"

# The installed programs start (their --help needs no store, server or network).
for program in fleetmap fleetmapd fleetmap-agent; do
  run "$program --help" "$prefix/bin/$program" --help
  head -n 1 "$log" | grep -q "^$program:" || {
    echo "$program --help did not print its description" >&2
    exit 1
  }
done

run "configure outside/ against the install" \
  "$cmake" -S "$source_dir/tests/install/outside" -B "$work/outside-build" -G Ninja \
  -DCMAKE_MAKE_PROGRAM="$ninja" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE="$build_type" \
  -DCMAKE_PREFIX_PATH="$prefix"
# CMAKE_PREFIX_PATH is searched first, but a fleetmap installed system-wide would also satisfy
# find_package: make sure it was this one.
grep -q "fleetmap package: $package_dir\$" "$log" || {
  step="check which fleetmap package was found"
  echo "found a fleetmap package other than $package_dir" >&2
  exit 1
}

run "build outside/" "$cmake" --build "$work/outside-build"

run "store_round_trip (write a node, reopen the store, read it back)" \
  "$work/outside-build/store_round_trip" "$work/store.db"
cat "$log"
grep -q "^round trip ok: node 01890a5d-ac96-7ab2-80e2-4536629c90de stamp_ns 1700000000123456789 landmarks 2 " "$log"

step="done"
echo "PASS: outside project built against the install and read its node back"
