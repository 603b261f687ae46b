-- Schema 8: a metric edge may carry the covariance of its pose. Logically the same as
-- sqlite/migrations/0008_edge_covariance.sql, which gives the layout of the 168 bytes.
ALTER TABLE edges ADD COLUMN covariance bytea
  CONSTRAINT edges_covariance_check
  CHECK (covariance IS NULL OR (octet_length(covariance) = 168 AND kind = 1));
