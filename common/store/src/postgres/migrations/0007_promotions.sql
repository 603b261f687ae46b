-- Schema 7: promotions (of the nightly dream's candidates). Logically the same as
-- sqlite/migrations/0007_promotions.sql, which explains kind 3.
ALTER TABLE revisions DROP CONSTRAINT revisions_kind_check;
ALTER TABLE revisions ADD CONSTRAINT revisions_kind_check CHECK (kind IN (1, 2, 3));
