-- Schema 1: the GraphDB of seed 000 §4.3.1 (nodes, edges, annotations) plus paths
-- (seed 002 §IV). Logically the same as sqlite/migrations/0001_graph.sql; UUIDs use the
-- native 16-byte uuid type.
CREATE TABLE nodes (
  id uuid PRIMARY KEY,
  stamp_ns bigint NOT NULL,
  robot uuid NOT NULL,
  outing uuid NOT NULL,
  landmarks bytea NOT NULL
);
CREATE INDEX nodes_by_robot ON nodes (robot, stamp_ns);
CREATE INDEX nodes_by_outing ON nodes (outing, stamp_ns);

CREATE TABLE paths (
  id uuid PRIMARY KEY,
  robot uuid NOT NULL,
  outing uuid NOT NULL,
  start_ns bigint NOT NULL,
  end_ns bigint NOT NULL
);
CREATE INDEX paths_by_robot ON paths (robot);
CREATE INDEX paths_by_outing ON paths (outing);

-- kind: 1 metric (from_T_to = translation + unit quaternion w,x,y,z), 2 path (non-metric).
CREATE TABLE edges (
  id uuid PRIMARY KEY,
  from_id uuid NOT NULL REFERENCES nodes (id),
  to_id uuid NOT NULL REFERENCES nodes (id),
  kind smallint NOT NULL CHECK (kind IN (1, 2)),
  tx double precision NOT NULL, ty double precision NOT NULL, tz double precision NOT NULL,
  qw double precision NOT NULL, qx double precision NOT NULL,
  qy double precision NOT NULL, qz double precision NOT NULL,
  path_id uuid REFERENCES paths (id),
  CHECK ((kind = 2) = (path_id IS NOT NULL))
);
CREATE INDEX edges_by_from ON edges (from_id);
CREATE INDEX edges_by_to ON edges (to_id);
CREATE INDEX edges_by_path ON edges (path_id) WHERE path_id IS NOT NULL;

-- Seed 000 §4.2: exactly one of node, edge, parent (see the SQLite migration for why these
-- are columns rather than the paper's link tables).
CREATE TABLE annotations (
  id uuid PRIMARY KEY,
  node_id uuid REFERENCES nodes (id),
  edge_id uuid REFERENCES edges (id),
  parent_id uuid REFERENCES annotations (id),
  type text NOT NULL,
  payload bytea NOT NULL,
  CHECK (num_nonnulls(node_id, edge_id, parent_id) = 1)
);
CREATE INDEX annotations_by_node ON annotations (node_id) WHERE node_id IS NOT NULL;
CREATE INDEX annotations_by_edge ON annotations (edge_id) WHERE edge_id IS NOT NULL;
CREATE INDEX annotations_by_parent ON annotations (parent_id) WHERE parent_id IS NOT NULL;
