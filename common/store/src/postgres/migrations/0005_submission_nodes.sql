-- Schema 5: what the server has seen of each node, beyond the map, so that nothing a robot
-- builds is ever lost. Logically the same as sqlite/migrations/0005_submission_nodes.sql,
-- which explains both tables.
CREATE TABLE submission_nodes (
  node uuid NOT NULL,
  submission uuid NOT NULL REFERENCES submissions (id),
  PRIMARY KEY (node, submission)
);

CREATE TABLE stand_ins (
  node uuid PRIMARY KEY,
  stand_in uuid NOT NULL REFERENCES nodes (id),
  tx double precision NOT NULL, ty double precision NOT NULL, tz double precision NOT NULL,
  qw double precision NOT NULL, qx double precision NOT NULL,
  qy double precision NOT NULL, qz double precision NOT NULL,
  revision bigint NOT NULL REFERENCES revisions (number)
);
CREATE INDEX stand_ins_by_revision ON stand_ins (revision);
