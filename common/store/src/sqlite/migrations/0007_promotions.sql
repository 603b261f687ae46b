-- Schema 7: promotions (of the nightly dream's candidates). Logically the same as
-- postgres/migrations/0007_promotions.sql. kind 3 is a promotion: a revision that makes a
-- dream's candidate map the map, adding what the candidate holds that the head lacks and
-- hiding the dreamed submissions' nodes it did without.
--
-- SQLite cannot change a CHECK constraint in place, so the table is rebuilt (it holds one
-- small row per revision). Stand-ins (schema 5) and reverts reference it: deferring the
-- foreign keys lets the rows leave and come back within this transaction, which the commit
-- then checks.
PRAGMA defer_foreign_keys = ON;
CREATE TEMP TABLE revisions_before_7 AS SELECT * FROM revisions;
DROP TABLE revisions;
CREATE TABLE revisions (
  number INTEGER PRIMARY KEY CHECK (number >= 1),
  created_ns INTEGER NOT NULL,
  author TEXT NOT NULL,
  kind INTEGER NOT NULL CHECK (kind IN (1, 2, 3)),
  submission BLOB,
  reverted INTEGER REFERENCES revisions (number),
  nodes_added INTEGER NOT NULL, edges_added INTEGER NOT NULL, paths_added INTEGER NOT NULL,
  nodes_hidden INTEGER NOT NULL, edges_hidden INTEGER NOT NULL, paths_hidden INTEGER NOT NULL,
  report TEXT NOT NULL,
  CHECK ((kind = 2) = (reverted IS NOT NULL))
);
INSERT INTO revisions SELECT * FROM revisions_before_7;
DROP TABLE revisions_before_7;
CREATE UNIQUE INDEX revisions_by_reverted ON revisions (reverted) WHERE reverted IS NOT NULL;
