-- Schema 3: the SQL index of raw sensor data (seed 000 §4.1; sensor_index.h). Logically the
-- same as postgres/migrations/0003_sensor_index.sql. The data themselves stay in record files
-- (record_file.h); a Data row says where its record lies.

CREATE TABLE platforms (
  platform_id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE CHECK (name <> '')
);

CREATE TABLE sensors (
  sensor_id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE CHECK (name <> ''),
  type TEXT NOT NULL
);

-- Seed 000 §4.1: a sensor may be mounted on more than one platform, though not at the same
-- time. A mount covers [from_ns, to_ns); to_ns NULL is "still mounted". The library refuses
-- overlapping mounts (checked and inserted in one transaction); the key keeps one mount of a
-- sensor per start.
CREATE TABLE sensor_mounts (
  sensor INTEGER NOT NULL REFERENCES sensors (sensor_id),
  platform INTEGER NOT NULL REFERENCES platforms (platform_id),
  from_ns INTEGER NOT NULL,
  to_ns INTEGER CHECK (to_ns IS NULL OR to_ns > from_ns),
  PRIMARY KEY (sensor, from_ns)
) WITHOUT ROWID;
CREATE INDEX sensor_mounts_by_platform ON sensor_mounts (platform, from_ns);

-- The record files the index points into (paths relative to the repository root). A file
-- gets its row with its first datum; ingest fills in size, mtime and records when it has read
-- the whole file (records 0 until then).
CREATE TABLE files (
  file_id INTEGER PRIMARY KEY,
  file TEXT NOT NULL UNIQUE CHECK (file <> ''),
  size INTEGER NOT NULL DEFAULT 0,
  mtime_ns INTEGER NOT NULL DEFAULT 0,
  records INTEGER NOT NULL DEFAULT 0
);

-- data_id is the rowid: the B-tree key of seed 000 §6 (select by id in O(log n)), and what
-- annotations refer to. (platform, sensor, stamp_ns) serves Eqs. 1-2 as a range scan; the
-- unique (file_id, offset) makes re-ingesting a file a no-op. The file is a reference into
-- files rather than its path: rows and the unique index are half the size, which is what a
-- bulk insert spends its time writing.
CREATE TABLE data (
  data_id INTEGER PRIMARY KEY,
  platform INTEGER NOT NULL REFERENCES platforms (platform_id),
  sensor INTEGER NOT NULL REFERENCES sensors (sensor_id),
  stamp_ns INTEGER NOT NULL,
  file_id INTEGER NOT NULL REFERENCES files (file_id),
  "offset" INTEGER NOT NULL CHECK ("offset" >= 0),
  length INTEGER NOT NULL CHECK (length > 0),
  type TEXT NOT NULL
);
CREATE INDEX data_by_platform_sensor_stamp ON data (platform, sensor, stamp_ns);
CREATE UNIQUE INDEX data_by_file_offset ON data (file_id, "offset");
