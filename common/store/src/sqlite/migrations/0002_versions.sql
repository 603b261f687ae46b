-- Schema 2: version control of the map (seed 004 §V; docs/data-model.md). Logically the
-- same as postgres/migrations/0002_versions.sql. UUIDs are 16-byte BLOBs; revision 0 is the
-- map before the first revision, so "no revision" is 0 or NULL, never a row.

-- Seed 004 §V: a robot's push is kept whole and immutable, so MERGE can be re-run from it
-- (in another order when dreaming, §VI-E). state: 0 receiving, 1 queued, 2 merged, 3 failed.
-- digest is the uint64 content digest bit-cast to a signed 64-bit integer (lossless).
CREATE TABLE submissions (
  id BLOB PRIMARY KEY NOT NULL CHECK (length(id) = 16),
  robot BLOB NOT NULL,
  author TEXT NOT NULL,
  received_ns INTEGER NOT NULL,
  chunk_count INTEGER NOT NULL DEFAULT 0,
  bytes INTEGER NOT NULL DEFAULT 0,
  digest INTEGER NOT NULL DEFAULT 0,
  state INTEGER NOT NULL DEFAULT 0 CHECK (state IN (0, 1, 2, 3)),
  revision INTEGER NOT NULL DEFAULT 0,
  error TEXT NOT NULL DEFAULT ''
) WITHOUT ROWID;
-- ListSubmissions returns them in the order they arrived.
CREATE INDEX submissions_by_received ON submissions (received_ns, id);

-- Chunks carry large blobs, so a rowid table (SQLite advises WITHOUT ROWID only for small
-- rows); the primary key keeps one copy of each (submission, seq), which is what makes a
-- resent chunk detectable.
CREATE TABLE submission_chunks (
  submission BLOB NOT NULL REFERENCES submissions (id),
  seq INTEGER NOT NULL CHECK (seq >= 0),
  data BLOB NOT NULL,
  PRIMARY KEY (submission, seq)
);

-- Seed 004 §V: a linear history like SVN. The primary key on number is what makes two
-- writers racing for head + 1 end in one revision and one conflict. kind: 1 merge, 2 revert.
-- The counts are what the revision really added and hid, kept for reports and checks.
CREATE TABLE revisions (
  number INTEGER PRIMARY KEY CHECK (number >= 1),
  created_ns INTEGER NOT NULL,
  author TEXT NOT NULL,
  kind INTEGER NOT NULL CHECK (kind IN (1, 2)),
  submission BLOB,
  reverted INTEGER REFERENCES revisions (number),
  nodes_added INTEGER NOT NULL, edges_added INTEGER NOT NULL, paths_added INTEGER NOT NULL,
  nodes_hidden INTEGER NOT NULL, edges_hidden INTEGER NOT NULL, paths_hidden INTEGER NOT NULL,
  report TEXT NOT NULL,
  CHECK ((kind = 2) = (reverted IS NOT NULL))
);
-- A revision is reverted at most once: a second revert of it must fail even when two
-- writers race.
CREATE UNIQUE INDEX revisions_by_reverted ON revisions (reverted) WHERE reverted IS NOT NULL;

-- Which revision added and hid each node, edge and path (kind: 1 node, 2 edge, 3 path). A
-- side table, not columns of nodes/edges/paths: the graph's insert paths stay as fast as
-- seed 000 Figs 6-7 measure them, and an element with no row here counts as added by
-- revision 0 and never hidden. Rows are only added and hidden_rev only set (a revert hides,
-- nothing un-hides), so every past revision can be checked out exactly: an element is visible
-- at r when added_rev <= r AND (hidden_rev IS NULL OR hidden_rev > r). added_rev is 0 for an
-- element from outside version control that a revert had to hide.
CREATE TABLE element_versions (
  id BLOB PRIMARY KEY NOT NULL CHECK (length(id) = 16),
  kind INTEGER NOT NULL CHECK (kind IN (1, 2, 3)),
  added_rev INTEGER NOT NULL CHECK (added_rev >= 0),
  hidden_rev INTEGER CHECK (hidden_rev > added_rev)
) WITHOUT ROWID;
-- A revert finds what a revision added; Changes finds what a range of revisions added or hid.
CREATE INDEX element_versions_by_added ON element_versions (added_rev);
CREATE INDEX element_versions_by_hidden ON element_versions (hidden_rev)
  WHERE hidden_rev IS NOT NULL;

-- Small named values of the repository (e.g. the appearance vocabulary).
CREATE TABLE settings (
  key TEXT PRIMARY KEY NOT NULL,
  value BLOB NOT NULL
) WITHOUT ROWID;
