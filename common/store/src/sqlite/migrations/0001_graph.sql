-- Schema 1: the GraphDB of seed 000 §4.3.1 (nodes, edges, annotations) plus paths
-- (seed 002 §IV). UUIDs are 16-byte BLOBs.
--
-- Nodes and annotations carry payload blobs, so they keep an integer key (seq) and a UNIQUE uuid (SQLite
-- advises WITHOUT ROWID only for small rows); edges and paths are small and keyed by uuid.
CREATE TABLE nodes (
  seq INTEGER PRIMARY KEY,
  id BLOB NOT NULL UNIQUE CHECK (length(id) = 16),
  stamp_ns INTEGER NOT NULL,
  robot BLOB NOT NULL,
  outing BLOB NOT NULL,
  landmarks BLOB NOT NULL
);
CREATE INDEX nodes_by_robot ON nodes (robot, stamp_ns);
CREATE INDEX nodes_by_outing ON nodes (outing, stamp_ns);

CREATE TABLE paths (
  id BLOB PRIMARY KEY NOT NULL CHECK (length(id) = 16),
  robot BLOB NOT NULL,
  outing BLOB NOT NULL,
  start_ns INTEGER NOT NULL,
  end_ns INTEGER NOT NULL
) WITHOUT ROWID;
CREATE INDEX paths_by_robot ON paths (robot);
CREATE INDEX paths_by_outing ON paths (outing);

-- kind: 1 metric (from_T_to = translation + unit quaternion w,x,y,z), 2 path (non-metric).
CREATE TABLE edges (
  id BLOB PRIMARY KEY NOT NULL CHECK (length(id) = 16),
  from_id BLOB NOT NULL REFERENCES nodes (id),
  to_id BLOB NOT NULL REFERENCES nodes (id),
  kind INTEGER NOT NULL CHECK (kind IN (1, 2)),
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  path_id BLOB REFERENCES paths (id),
  CHECK ((kind = 2) = (path_id IS NOT NULL))
) WITHOUT ROWID;
CREATE INDEX edges_by_from ON edges (from_id);
CREATE INDEX edges_by_to ON edges (to_id);
CREATE INDEX edges_by_path ON edges (path_id) WHERE path_id IS NOT NULL;

-- Seed 000 §4.2: an annotation is on exactly one thing. The paper links annotations to
-- nodes and edges through link tables; ours have exactly one target each, so three nullable
-- foreign keys with a CHECK say the same thing with the database enforcing both rules.
CREATE TABLE annotations (
  seq INTEGER PRIMARY KEY,
  id BLOB NOT NULL UNIQUE CHECK (length(id) = 16),
  node_id BLOB REFERENCES nodes (id),
  edge_id BLOB REFERENCES edges (id),
  parent_id BLOB REFERENCES annotations (id),
  type TEXT NOT NULL,
  payload BLOB NOT NULL,
  CHECK ((node_id IS NOT NULL) + (edge_id IS NOT NULL) + (parent_id IS NOT NULL) = 1)
);
CREATE INDEX annotations_by_node ON annotations (node_id) WHERE node_id IS NOT NULL;
CREATE INDEX annotations_by_edge ON annotations (edge_id) WHERE edge_id IS NOT NULL;
CREATE INDEX annotations_by_parent ON annotations (parent_id) WHERE parent_id IS NOT NULL;
