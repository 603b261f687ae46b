-- Schema 8: a metric edge may carry the covariance of its pose (fleetmap/core/graph.h
-- Edge::covariance). Logically the same as postgres/migrations/0008_edge_covariance.sql.
--
-- The 6 x 6 matrix is symmetric, so the blob holds its upper triangle: 21 little-endian IEEE
-- 754 doubles, row by row (edge_covariance_blob.h), 168 bytes. NULL is an edge without one,
-- which is every edge stored before this schema. Whether the numbers make a covariance (finite,
-- positive semi-definite) is checked by the code that writes and reads them, not here.
ALTER TABLE edges ADD COLUMN covariance BLOB
  CHECK (covariance IS NULL OR (typeof(covariance) = 'blob' AND length(covariance) = 168
                                AND kind = 1));
