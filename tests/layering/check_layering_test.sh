#!/usr/bin/env bash
# scripts/check-layering on small trees made here: a clean one passes, and each rule it states
# fails on a tree that breaks only that rule, naming the offending file.
set -euo pipefail
check=${1:?usage: check_layering_test.sh PATH/TO/check-layering}
work=$(mktemp -d /tmp/fleetmap-layering-test.XXXXXX)
trap 'rm -rf "$work"' EXIT

# Two libraries, fleetmap_core and fleetmap_ebn (ebn may use core), plus fleetmap_store.
make_tree() {
  rm -rf "$work/tree"
  for lib in core ebn store; do
    mkdir -p "$work/tree/$lib/include/fleetmap/$lib" "$work/tree/$lib/src"
    printf '#pragma once\n' >"$work/tree/$lib/include/fleetmap/$lib/$lib.h"
    printf '#pragma once\n' >"$work/tree/$lib/src/${lib}_detail.h"
    printf '#include "fleetmap/%s/%s.h"\n#include "%s_detail.h"\n#include <vector>\n' \
      "$lib" "$lib" "$lib" >"$work/tree/$lib/src/$lib.cc"
  done
  printf '#include "fleetmap/core/core.h"\n' >>"$work/tree/ebn/include/fleetmap/ebn/ebn.h"
  printf '#include "fleetmap/core/core.h"\n' >>"$work/tree/store/src/store.cc"
  layering "fleetmap_core||" "fleetmap_ebn|fleetmap_core|" "fleetmap_store|fleetmap_core|"
}
layering() {
  : >"$work/layering.txt"
  for line in "$@"; do
    IFS='|' read -r name public private <<<"$line"
    echo "$name|$work/tree/${name#fleetmap_}|$public|$private" >>"$work/layering.txt"
  done
}
expect_pass() {
  if ! "$check" --layering "$work/layering.txt" >"$work/out" 2>&1; then
    echo "FAIL: $1: check-layering refused a clean tree:"; cat "$work/out"; exit 1
  fi
  echo "ok: $1"
}
expect_fail() {  # what, a string the message must hold
  if "$check" --layering "$work/layering.txt" >"$work/out" 2>&1; then
    echo "FAIL: $1: check-layering passed"; cat "$work/out"; exit 1
  fi
  if ! grep -qF -- "$2" "$work/out"; then
    echo "FAIL: $1: the message does not say '$2':"; cat "$work/out"; exit 1
  fi
  echo "ok: $1"
}

make_tree
expect_pass "a clean tree"

make_tree
printf '#include "fleetmap/store/store.h"\n' >>"$work/tree/ebn/src/ebn.cc"
expect_fail "a header of a library not linked" "ebn/src/ebn.cc:4: fleetmap_ebn includes fleetmap/store/store.h, a header of fleetmap_store, which it does not link"

make_tree
layering "fleetmap_core||" "fleetmap_ebn||fleetmap_core" "fleetmap_store|fleetmap_core|"
expect_fail "a public header using a private dependency" "in a public header, but links fleetmap_core only privately"

make_tree
printf '#include "../../store/src/store_detail.h"\n' >>"$work/tree/ebn/src/ebn.cc"
expect_fail "another library's private header" "a private header of fleetmap_store"

make_tree
printf '#include "ebn_detail.h"\n' >>"$work/tree/ebn/include/fleetmap/ebn/ebn.h"
expect_fail "a public header including its own private one" "a public header includes a private one"

make_tree
printf '#include "fleetmap/nowhere/thing.h"\n' >>"$work/tree/core/src/core.cc"
expect_fail "a header no library holds" "which no library's include/ holds"

make_tree
layering "fleetmap_core|fleetmap_ebn|" "fleetmap_ebn|fleetmap_core|" "fleetmap_store|fleetmap_core|"
expect_fail "a link cycle" "link cycle"

make_tree
layering "fleetmap_core||" "fleetmap_ebn|fleetmap_core fleetmap_store|" "fleetmap_store|fleetmap_core|"
expect_fail "ebn linking the store (docs/architecture.md: ebn may use core only)" "fleetmap_ebn reaches fleetmap_store through its links"

make_tree
for i in $(seq 1 12); do printf '#pragma once\n' >"$work/tree/core/include/fleetmap/core/extra$i.h"; done
expect_fail "a public folder of 13 headers" "13 public headers (at most 12)"

echo "check-layering: every rule refuses the tree that breaks it"

make_tree
mkdir -p "$work/tree/ebn/include/fleetmap/other"
printf '#pragma once\n' >"$work/tree/ebn/include/fleetmap/other/thing.h"
expect_fail "a public header under another library's prefix" "a public header of fleetmap_ebn under fleetmap/other/, not fleetmap/ebn/"

make_tree
mv "$work/tree/store" "$work/tree/storage"
sed -i "s#/tree/store|#/tree/storage|#" "$work/layering.txt"
expect_fail "a library in a folder not named for it" "fleetmap_store lives in a folder named storage, not store"
