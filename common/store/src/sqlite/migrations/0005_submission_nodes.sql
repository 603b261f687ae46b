-- Schema 5: what the server has seen of each node, beyond the map, so that nothing a robot
-- builds is ever lost. Logically the same as postgres/migrations/0005_submission_nodes.sql.

-- Which submissions carried each node. A robot builds on nodes it pushed before their merge
-- is in its download (still queued, or merged but omitted), so a later push may have edges to
-- them: the server accepts such an edge because it has seen the node, not because the map
-- holds it.
CREATE TABLE submission_nodes (
  node BLOB NOT NULL CHECK (length(node) = 16),
  submission BLOB NOT NULL REFERENCES submissions (id),
  PRIMARY KEY (node, submission)
) WITHOUT ROWID;

-- Seed 004 §V-A: MERGE omits a submitted node whose stretch already localises; the server
-- node it localised in (or was placed by through a localised neighbour) stands in for it, at
-- pose stand_in_T_node (translation + unit quaternion w,x,y,z, as edges). Kept so that an edge
-- pushed later to the omitted node is carried onto its stand-in, and so that every node a
-- robot pushed is accounted for: in the map, or here.
CREATE TABLE stand_ins (
  node BLOB PRIMARY KEY NOT NULL CHECK (length(node) = 16),
  stand_in BLOB NOT NULL REFERENCES nodes (id),
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  revision INTEGER NOT NULL REFERENCES revisions (number)
) WITHOUT ROWID;
CREATE INDEX stand_ins_by_revision ON stand_ins (revision);
