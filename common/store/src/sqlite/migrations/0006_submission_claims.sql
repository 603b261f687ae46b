-- Schema 6: several fleetmapd on one store. Logically the same as
-- postgres/migrations/0006_submission_claims.sql.
--
-- A queued submission is merged by the one instance that holds its claim: claimed_by names
-- the instance ('' when none ever claimed it) and lease_until_ns is when the claim ends (UTC
-- ns) unless renewed. An instance that dies mid-merge loses nothing: its lease ends and
-- another claims the submission, still queued.
ALTER TABLE submissions ADD COLUMN claimed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE submissions ADD COLUMN lease_until_ns INTEGER NOT NULL DEFAULT 0;
-- Claiming looks for the oldest queued submission; merged ones, the great majority, stay out.
CREATE INDEX submissions_queued ON submissions (received_ns, id) WHERE state = 1;
