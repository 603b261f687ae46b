-- Schema 9: retirement. Logically the same as sqlite/migrations/0009_retirement.sql, which
-- explains kind 4, the retirements table and node_usage.
ALTER TABLE revisions DROP CONSTRAINT revisions_kind_check;
ALTER TABLE revisions ADD CONSTRAINT revisions_kind_check CHECK (kind IN (1, 2, 3, 4));

CREATE TABLE retirements (
  id uuid NOT NULL,
  kind smallint NOT NULL CHECK (kind IN (1, 2, 3)),
  retired_rev bigint NOT NULL CHECK (retired_rev >= 1),
  restored_rev bigint CHECK (restored_rev > retired_rev),
  PRIMARY KEY (id, retired_rev)
);
CREATE INDEX retirements_by_retired ON retirements (retired_rev);
CREATE INDEX retirements_by_restored ON retirements (restored_rev) WHERE restored_rev IS NOT NULL;

CREATE TABLE node_usage (
  node uuid NOT NULL,
  revision bigint NOT NULL CHECK (revision >= 1),
  source smallint NOT NULL CHECK (source IN (1, 2)),
  frames bigint NOT NULL CHECK (frames >= 0),
  last_ns bigint NOT NULL,
  PRIMARY KEY (node, revision, source)
);
CREATE INDEX node_usage_by_revision ON node_usage (revision);
