-- Schema 9: retirement (server/repository/include/fleetmap/repository/retirement.h). Logically
-- the same as postgres/migrations/0009_retirement.sql.
--
-- kind 4 is a retirement: a revision that hides experiences nobody localises against any more.
-- Unlike a revert or a promotion it must be undoable, and element_versions only ever hides
-- (so that every past revision checks out exactly). Its hiding is kept apart instead: one row
-- per element and retirement, closed by the revert that restored it. An element is visible at
-- r when element_versions says so and no retirement of it is open at r:
--   NOT (retired_rev <= r AND (restored_rev IS NULL OR restored_rev > r)).
-- The table is empty until a first retirement, so other stores pay one probe of an empty
-- index per element read.
CREATE TABLE retirements (
  id BLOB NOT NULL CHECK (length(id) = 16),
  kind INTEGER NOT NULL CHECK (kind IN (1, 2, 3)),
  retired_rev INTEGER NOT NULL CHECK (retired_rev >= 1),
  restored_rev INTEGER CHECK (restored_rev > retired_rev),
  PRIMARY KEY (id, retired_rev)
) WITHOUT ROWID;
-- A revert of a retirement finds what it hid; Changes finds what a range retired or restored.
CREATE INDEX retirements_by_retired ON retirements (retired_rev);
CREATE INDEX retirements_by_restored ON retirements (restored_rev) WHERE restored_rev IS NOT NULL;

-- Which nodes robots localise against, as each revision measured it (a MERGE's replay of the
-- submission's frames, seed 004 §V-A; source 1), or as a robot reported it (source 2): frames
-- that localised against the node and the newest frame's stamp (UTC ns). Retirement reads the
-- newest use of each node.
CREATE TABLE node_usage (
  node BLOB NOT NULL CHECK (length(node) = 16),
  revision INTEGER NOT NULL CHECK (revision >= 1),
  source INTEGER NOT NULL CHECK (source IN (1, 2)),
  frames INTEGER NOT NULL CHECK (frames >= 0),
  last_ns INTEGER NOT NULL,
  PRIMARY KEY (node, revision, source)
) WITHOUT ROWID;
CREATE INDEX node_usage_by_revision ON node_usage (revision);

-- SQLite cannot change a CHECK constraint in place: the revisions table is rebuilt as schema 7
-- did (see there for the deferred foreign keys).
PRAGMA defer_foreign_keys = ON;
CREATE TEMP TABLE revisions_before_9 AS SELECT * FROM revisions;
DROP TABLE revisions;
CREATE TABLE revisions (
  number INTEGER PRIMARY KEY CHECK (number >= 1),
  created_ns INTEGER NOT NULL,
  author TEXT NOT NULL,
  kind INTEGER NOT NULL CHECK (kind IN (1, 2, 3, 4)),
  submission BLOB,
  reverted INTEGER REFERENCES revisions (number),
  nodes_added INTEGER NOT NULL, edges_added INTEGER NOT NULL, paths_added INTEGER NOT NULL,
  nodes_hidden INTEGER NOT NULL, edges_hidden INTEGER NOT NULL, paths_hidden INTEGER NOT NULL,
  report TEXT NOT NULL,
  CHECK ((kind = 2) = (reverted IS NOT NULL))
);
INSERT INTO revisions SELECT * FROM revisions_before_9;
DROP TABLE revisions_before_9;
CREATE UNIQUE INDEX revisions_by_reverted ON revisions (reverted) WHERE reverted IS NOT NULL;
