-- Schema 6: several fleetmapd on one store. Logically the same as
-- sqlite/migrations/0006_submission_claims.sql, which explains the columns. Leases are
-- measured by this server's clock, so instances on hosts whose clocks disagree still agree
-- on when a lease ends.
ALTER TABLE submissions ADD COLUMN claimed_by text NOT NULL DEFAULT '';
ALTER TABLE submissions ADD COLUMN lease_until_ns bigint NOT NULL DEFAULT 0;
CREATE INDEX submissions_queued ON submissions (received_ns, id) WHERE state = 1;
