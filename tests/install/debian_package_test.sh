#!/usr/bin/env bash
# The Debian package and the services as a fresh machine gets them (docs/operations.md,
# "Run as services"): `cpack -G DEB` from the finished build into a temporary directory; the
# package's control fields, conffiles and files; every shared library the programs load comes
# from a package its Depends names, and every Depends is installed here in a version it allows;
# the programs, extracted with `dpkg-deb -x`, run (`--help`); the units pass `systemd-analyze
# verify` and score OK or better in `systemd-analyze security`, start the programs with
# --config and never with a token in argv; its sysusers.d entry makes the user (in a temporary
# root). Then `cmake --install --component runtime` into a temporary prefix: units configured
# for that prefix, a site's edited config kept.
#
# Installing with dpkg needs root and changes the machine (users, units), so the package is
# unpacked and run instead; its maintainer scripts are checked for syntax only.
#
# usage: debian_package_test.sh BUILD_DIR WORK_PARENT CPACK CMAKE VERSION
# (tests/install/CMakeLists.txt passes these). REQUIRES: BUILD_DIR fully built.
set -euo pipefail

if [ $# -ne 5 ]; then
  echo "usage: $0 BUILD_DIR WORK_PARENT CPACK CMAKE VERSION" >&2
  exit 2
fi
build_dir=$1 work_parent=$2 cpack=$3 cmake=$4 version=$5
source "$(dirname "$0")/install_test_steps.sh"
install_test_start "$work_parent" debian_package

run "cpack -G DEB" "$cpack" -G DEB --config "$build_dir/CPackConfig.cmake" -B "$work/package"
deb=$work/package/fleetmap_${version}_$(dpkg --print-architecture).deb
[ -f "$deb" ] || fail "no $deb; cpack made: $(ls "$work/package")"

step="control fields"
echo "== $step"
field() { dpkg-deb --field "$deb" "$1"; }
[ "$(field Package)" = fleetmap ] || fail "Package: $(field Package)"
[ "$(field Version)" = "$version" ] || fail "Version: $(field Version), the project is $version"
[ -n "$(field Maintainer)" ] || fail "no Maintainer"
[ -n "$(field Description)" ] || fail "no Description"
depends=$(field Depends)
echo "   Depends: $depends"
dpkg-deb --ctrl-tarfile "$deb" | tar -x -C "$work" ./postinst ./postrm ./conffiles ||
  fail "the control archive lacks postinst, postrm or conffiles"
for script in postinst postrm; do sh -n "$work/$script" || fail "$script: bad shell syntax"; done
for conffile in /etc/fleetmap/fleetmapd.toml /etc/fleetmap/agent.toml; do
  grep -qx "$conffile" "$work/conffiles" || fail "$conffile is not a conffile"
done

step="files"
echo "== $step"
dpkg-deb --contents "$deb" | awk '{print $NF}' | sed 's|^\./|/|' >"$work/contents"
for file in /usr/bin/fleetmap /usr/bin/fleetmapd /usr/bin/fleetmap-agent \
            /usr/lib/systemd/system/fleetmapd.service \
            /usr/lib/systemd/system/fleetmap-agent.service \
            /etc/fleetmap/fleetmapd.toml /etc/fleetmap/agent.toml \
            /usr/lib/sysusers.d/fleetmap.conf /usr/share/doc/fleetmap/README.md \
            /usr/share/doc/fleetmap/docs/operations.md; do
  grep -qx "$file" "$work/contents" || fail "not in the package: $file"
done
# Only the programs and services: the static libraries and headers are for `cmake --install`.
if grep -E '\.a$|/include/' "$work/contents"; then fail "development files in the package"; fi
root=$work/root
dpkg-deb -x "$deb" "$root"

step="every library the programs load comes from a package in Depends"
echo "== $step"
# The names an installed package provides: "libspdlog1.10" -> libspdlog1.10-fmt9.
provided_by() {
  dpkg-query -W -f='${Provides}' "$1" | tr ',' '\n' | sed 's/(.*)//; s/ //g'
}
# Depends as package names: "a (>= 1), b | c" -> a b c.
depends_names=" $(echo "$depends" | tr ',|' '\n\n' | sed 's/(.*)//; s/ //g' | tr '\n' ' ') "
# Each program's libraries as ldd resolves them, and the paths dpkg may know each by (/lib or
# /usr/lib: merged /usr). One dpkg-query for them all: each call reads dpkg's whole file list
# (0.15 s), and one call per library took 12 of this test's 22 s.
declare -A library_path=()
candidates=()
for program in fleetmap fleetmapd fleetmap-agent; do
  binary=$root/usr/bin/$program
  ldd "$binary" >"$log" 2>&1 || fail "ldd $program"
  if grep -q "not found" "$log"; then fail "$program: a library is missing"; fi
  for needed in $(readelf -d "$binary" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    path=$(awk -v lib="$needed" '$1 == lib && $2 == "=>" {print $3}' "$log")
    [ -n "$path" ] || fail "$program: ldd does not resolve $needed"
    library_path["$program $needed"]=$path
    candidates+=("$path" "$(readlink -f "$path")" "${path#/usr}" "/usr$path")
  done
done
# "libpng16-16:amd64: /usr/lib/x86_64-linux-gnu/libpng16.so.16" -> owner_of[path]=libpng16-16
declare -A owner_of=()
while IFS= read -r line; do
  case "$line" in *": /"*) owner_of["${line##*: }"]=${line%%:*} ;; esac
done < <(dpkg-query -S "${candidates[@]}" 2>/dev/null || true)
for key in "${!library_path[@]}"; do
  program=${key%% *} needed=${key#* } path=${library_path[$key]}
  owner=""
  for candidate in "$path" "$(readlink -f "$path")" "${path#/usr}" "/usr$path"; do
    if [ -n "${owner_of[$candidate]:-}" ]; then
      owner=${owner_of[$candidate]}
      break
    fi
  done
  [ -n "$owner" ] || fail "$program: no package ships $path ($needed)"
  # Depends may name the package or a name it provides (libspdlog1.10 provides
  # libspdlog1.10-fmt9, the name its shlibs file gives).
  named=""
  for name in $owner $(provided_by "$owner"); do
    case "$depends_names" in *" $name "*) named=$name ;; esac
  done
  [ -n "$named" ] || fail "$program loads $needed from $owner, which Depends does not name"
done

step="every Depends is installed in a version it allows"
echo "== $step"
installed_provides=$(dpkg-query -W -f='${db:Status-Status} ${Provides}\n' |
  sed -n 's/^installed //p' | tr ',' '\n' | sed 's/(.*)//; s/ //g')
IFS=',' read -r -a clauses <<<"$depends"
for clause in "${clauses[@]}"; do
  satisfied=""
  IFS='|' read -r -a alternatives <<<"$clause"
  for alternative in "${alternatives[@]}"; do
    name=$(echo "$alternative" | sed 's/(.*)//; s/ //g')
    relation=$(echo "$alternative" | sed -n 's/.*(\(.*\)).*/\1/p')
    installed=$(dpkg-query -W -f='${db:Status-Status} ${Version}' "$name" 2>/dev/null || true)
    if [ "${installed%% *}" != installed ]; then
      # A name only provided (unversioned): met by any installed package providing it.
      if [ -z "$relation" ] && grep -qx -- "$name" <<<"$installed_provides"; then
        satisfied=$name
        break
      fi
      continue
    fi
    if [ -z "$relation" ] ||
       dpkg --compare-versions "${installed#* }" ${relation%% *} ${relation#* }; then
      satisfied=$name
      break
    fi
  done
  [ -n "$satisfied" ] || fail "Depends '$clause' is not satisfied on this machine"
done

# The unpacked programs start: their --help needs no store, server or network.
for program in fleetmap fleetmapd fleetmap-agent; do
  run "the package's $program --help" "$root/usr/bin/$program" --help
  [[ "$(head -n 1 "$log")" == "$program:"* ]] ||
    fail "$program --help did not print its description"
done

step="units"
echo "== $step"
units=$root/usr/lib/systemd/system
grep -qx "ExecStart=/usr/bin/fleetmapd --config /etc/fleetmap/fleetmapd.toml" \
  "$units/fleetmapd.service" || fail "fleetmapd.service: ExecStart"
agent_exec="/usr/bin/fleetmap-agent --config /etc/fleetmap/agent.toml daemon --token-file %d/token"
grep -qx "ExecStart=$agent_exec" \
  "$units/fleetmap-agent.service" || fail "fleetmap-agent.service: ExecStart"
grep -qx "LoadCredential=token:/etc/fleetmap/agent.token" "$units/fleetmap-agent.service" ||
  fail "fleetmap-agent.service: the token is not a credential"
for unit in fleetmapd fleetmap-agent; do
  file=$units/$unit.service
  # A token never in argv: no --token option (only --token-file), no token-like string.
  if grep -E '^Exec.*(--token( |=)|[0-9a-f]{32})' "$file"; then fail "$unit: a token in argv"; fi
  for key in User=fleetmap StateDirectory= ProtectSystem=strict ProtectHome=yes PrivateTmp=yes \
             NoNewPrivileges=yes "RestrictAddressFamilies=AF_INET AF_INET6 AF_UNIX" \
             CapabilityBoundingSet= SystemCallFilter=@system-service; do
    grep -q "^$key" "$file" || fail "$unit.service: no $key"
  done
  # systemd-analyze checks that the programs exist: point the copy at the unpacked ones.
  sed "s|/usr/bin/|$root/usr/bin/|g" "$file" >"$work/$unit.service"
  run "systemd-analyze verify $unit.service" systemd-analyze verify "$work/$unit.service"
  [ ! -s "$log" ] || fail "systemd-analyze verify $unit.service warned"
  run "systemd-analyze security $unit.service" \
    systemd-analyze security --offline=true "$work/$unit.service"
  exposure=$(sed -n 's/.*Overall exposure level for .*: \([0-9.]*\) .*/\1/p' "$log")
  echo "   exposure $exposure"
  awk -v e="$exposure" 'BEGIN { exit !(e != "" && e <= 2.0) }' ||
    fail "$unit.service exposure '$exposure', above 2.0 (systemd-analyze security)"
done

# The user the units run as, made by the postinst's systemd-sysusers: here into an empty root.
sysroot=$work/sysroot
mkdir -p "$sysroot/etc"
touch "$sysroot/etc/passwd" "$sysroot/etc/group" "$sysroot/etc/shadow" "$sysroot/etc/gshadow"
run "systemd-sysusers fleetmap.conf (into a temporary root)" \
  systemd-sysusers --root="$sysroot" "$root/usr/lib/sysusers.d/fleetmap.conf"
grep -q '^fleetmap:x:[0-9]*:[0-9]*:.*:/var/lib/fleetmap:/usr/sbin/nologin$' "$sysroot/etc/passwd" ||
  fail "sysusers.d/fleetmap.conf did not make the system user fleetmap"

# cmake --install writes the units for its own prefix and keeps a site's config.
prefix=$work/prefix
run "cmake --install --component runtime --prefix <tmp>" \
  "$cmake" --install "$build_dir" --component runtime --prefix "$prefix"
step="the units and configs of cmake --install"
echo "== $step"
grep -qx "ExecStart=$prefix/bin/fleetmapd --config $prefix/etc/fleetmap/fleetmapd.toml" \
  "$prefix/lib/systemd/system/fleetmapd.service" || fail "fleetmapd.service for $prefix"
cmp "$prefix/etc/fleetmap/agent.toml" "$root/etc/fleetmap/agent.toml" ||
  fail "the installed agent.toml differs from the package's"
echo 'store = "sqlite:/srv/fleet.db"' >"$prefix/etc/fleetmap/fleetmapd.toml"
run "cmake --install again over an edited config" \
  "$cmake" --install "$build_dir" --component runtime --prefix "$prefix"
grep -qx 'store = "sqlite:/srv/fleet.db"' "$prefix/etc/fleetmap/fleetmapd.toml" ||
  fail "a second install overwrote the site's fleetmapd.toml"

step="done"
echo "PASS: $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB) unpacks and runs; units verified"
