# Sourced, not run: a throwaway PostgreSQL cluster on 127.0.0.1 for tests and benchmarks.
#   pg_throwaway_start   initdb in a temp dir (tmpfs if there is one), start on a free port, export
#                        FLEETMAP_TEST_PG_URI (a superuser "fleetmap", trust auth, loopback only)
#   pg_throwaway_stop    stop it and delete the directory (safe to call twice)
# As root, the server runs as the unprivileged user "nobody" (postgres refuses root).

pg_throwaway_start() {
  local bin
  bin=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1)
  if [ -z "$bin" ] || [ ! -x "$bin/initdb" ]; then
    echo "pg: no PostgreSQL server binaries under /usr/lib/postgresql (run scripts/setup)" >&2
    return 1
  fi
  # In memory (tmpfs) where there is one: every test makes and drops a database of ~300 files,
  # and on a well-used ext4 disk CREATE DATABASE took 370 ms, most of it in the kernel finding
  # free inodes (perf), against 23 ms on tmpfs. The cluster is thrown away: nothing is lost.
  local parent=${TMPDIR:-/tmp}
  if [ -d /dev/shm ] && [ -w /dev/shm ]; then parent=/dev/shm; fi
  PG_THROWAWAY_DIR=$(mktemp -d "$parent/fleetmap-pg.XXXXXX")
  PG_THROWAWAY_RUN=()
  if [ "$(id -u)" -eq 0 ]; then
    chown nobody "$PG_THROWAWAY_DIR"
    PG_THROWAWAY_RUN=(runuser -u nobody --)
  fi
  PG_THROWAWAY_BIN=$bin
  if ! "${PG_THROWAWAY_RUN[@]}" "$bin/initdb" -D "$PG_THROWAWAY_DIR/data" -U fleetmap \
      --auth=trust -E UTF8 --no-sync >"$PG_THROWAWAY_DIR/initdb.log" 2>&1; then
    cat "$PG_THROWAWAY_DIR/initdb.log" >&2
    return 1
  fi
  # A cluster that lives as long as one run need not survive the machine losing power: no
  # fsync (a killed or restarted server still finds every commit in the kernel's cache, as the
  # tests that kill it expect), which took a tenth off the PostgreSQL tests' time.
  local PG_THROWAWAY_NO_FSYNC="-c fsync=off -c full_page_writes=off"
  local attempt port
  for attempt in 1 2 3 4 5 6 7 8; do
    port=$((20000 + RANDOM % 40000))
    # Something already answers there: try another port.
    if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then continue; fi
    if "${PG_THROWAWAY_RUN[@]}" "$bin/pg_ctl" -D "$PG_THROWAWAY_DIR/data" \
        -l "$PG_THROWAWAY_DIR/server.log" -w -t 60 \
        -o "-p $port -k $PG_THROWAWAY_DIR -c listen_addresses=127.0.0.1 -c max_connections=100 $PG_THROWAWAY_NO_FSYNC" \
        start >/dev/null 2>&1; then
      export FLEETMAP_TEST_PG_URI="postgresql://fleetmap@127.0.0.1:$port/postgres"
      echo "pg: throwaway PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on 127.0.0.1:$port ($PG_THROWAWAY_DIR)" >&2
      return 0
    fi
  done
  tail -n 20 "$PG_THROWAWAY_DIR/server.log" >&2 || true
  echo "pg: could not start a throwaway cluster" >&2
  return 1
}

pg_throwaway_stop() {
  [ -n "${PG_THROWAWAY_DIR:-}" ] || return 0
  if [ -f "$PG_THROWAWAY_DIR/data/postmaster.pid" ]; then
    "${PG_THROWAWAY_RUN[@]}" "$PG_THROWAWAY_BIN/pg_ctl" -D "$PG_THROWAWAY_DIR/data" -m immediate \
      -w -t 30 stop >/dev/null 2>&1 || true
  fi
  rm -rf "$PG_THROWAWAY_DIR"
  PG_THROWAWAY_DIR=
}
