-- Schema 2: version control of the map (seed 004 §V; docs/data-model.md). Logically the
-- same as sqlite/migrations/0002_versions.sql (see there for the full reasoning); revision 0
-- is the map before the first revision, so "no revision" is 0 or NULL, never a row.

-- Seed 004 §V: a robot's push is kept whole and immutable, so MERGE can be re-run from it
-- (in another order when dreaming, §VI-E). state: 0 receiving, 1 queued, 2 merged, 3 failed.
-- digest is the uint64 content digest bit-cast to bigint (lossless).
CREATE TABLE submissions (
  id uuid PRIMARY KEY,
  robot uuid NOT NULL,
  author text NOT NULL,
  received_ns bigint NOT NULL,
  chunk_count bigint NOT NULL DEFAULT 0,
  bytes bigint NOT NULL DEFAULT 0,
  digest bigint NOT NULL DEFAULT 0,
  state smallint NOT NULL DEFAULT 0 CHECK (state IN (0, 1, 2, 3)),
  revision bigint NOT NULL DEFAULT 0,
  error text NOT NULL DEFAULT ''
);
-- ListSubmissions returns them in the order they arrived.
CREATE INDEX submissions_by_received ON submissions (received_ns, id);

-- One copy of each (submission, seq): what makes a resent chunk detectable.
CREATE TABLE submission_chunks (
  submission uuid NOT NULL REFERENCES submissions (id),
  seq bigint NOT NULL CHECK (seq >= 0),
  data bytea NOT NULL,
  PRIMARY KEY (submission, seq)
);

-- Seed 004 §V: a linear history like SVN. The primary key on number is what makes two
-- writers racing for head + 1 end in one revision and one conflict. kind: 1 merge, 2 revert.
CREATE TABLE revisions (
  number bigint PRIMARY KEY CHECK (number >= 1),
  created_ns bigint NOT NULL,
  author text NOT NULL,
  kind smallint NOT NULL CHECK (kind IN (1, 2)),
  submission uuid,
  reverted bigint REFERENCES revisions (number),
  nodes_added bigint NOT NULL, edges_added bigint NOT NULL, paths_added bigint NOT NULL,
  nodes_hidden bigint NOT NULL, edges_hidden bigint NOT NULL, paths_hidden bigint NOT NULL,
  report text NOT NULL,
  CHECK ((kind = 2) = (reverted IS NOT NULL))
);
-- A revision is reverted at most once, also when two writers race.
CREATE UNIQUE INDEX revisions_by_reverted ON revisions (reverted) WHERE reverted IS NOT NULL;

-- Which revision added and hid each node, edge and path (kind: 1 node, 2 edge, 3 path). A
-- side table, so the graph's insert paths (seed 000 Figs 6-7) are untouched; an element with
-- no row here counts as added by revision 0 and never hidden. A revert only sets hidden_rev,
-- nothing un-hides, so every past revision can be checked out exactly: visible at r when
-- added_rev <= r AND (hidden_rev IS NULL OR hidden_rev > r).
CREATE TABLE element_versions (
  id uuid PRIMARY KEY,
  kind smallint NOT NULL CHECK (kind IN (1, 2, 3)),
  added_rev bigint NOT NULL CHECK (added_rev >= 0),
  hidden_rev bigint CHECK (hidden_rev > added_rev)
);
-- A revert finds what a revision added; Changes finds what a range of revisions added or hid.
CREATE INDEX element_versions_by_added ON element_versions (added_rev);
CREATE INDEX element_versions_by_hidden ON element_versions (hidden_rev)
  WHERE hidden_rev IS NOT NULL;

-- Small named values of the repository (e.g. the appearance vocabulary).
CREATE TABLE settings (
  key text PRIMARY KEY,
  value bytea NOT NULL
);
