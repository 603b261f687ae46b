-- Schema 3: the SQL index of raw sensor data (seed 000 §4.1; sensor_index.h). Logically the
-- same as sqlite/migrations/0003_sensor_index.sql (see there for the reasoning).

CREATE TABLE platforms (
  platform_id bigserial PRIMARY KEY,
  name text NOT NULL UNIQUE CHECK (name <> '')
);

CREATE TABLE sensors (
  sensor_id bigserial PRIMARY KEY,
  name text NOT NULL UNIQUE CHECK (name <> ''),
  type text NOT NULL
);

-- [from_ns, to_ns); to_ns NULL is "still mounted". Overlaps are refused by the library, which
-- locks the sensor's row (FOR UPDATE) while it checks and inserts, so two writers cannot both
-- mount one sensor on two platforms at once.
CREATE TABLE sensor_mounts (
  sensor bigint NOT NULL REFERENCES sensors (sensor_id),
  platform bigint NOT NULL REFERENCES platforms (platform_id),
  from_ns bigint NOT NULL,
  to_ns bigint CHECK (to_ns IS NULL OR to_ns > from_ns),
  PRIMARY KEY (sensor, from_ns)
);
CREATE INDEX sensor_mounts_by_platform ON sensor_mounts (platform, from_ns);

-- A file gets its row with its first datum; ingest fills in size, mtime and records.
CREATE TABLE files (
  file_id bigserial PRIMARY KEY,
  file text NOT NULL UNIQUE CHECK (file <> ''),
  size bigint NOT NULL DEFAULT 0,
  mtime_ns bigint NOT NULL DEFAULT 0,
  records bigint NOT NULL DEFAULT 0
);

CREATE TABLE data (
  data_id bigserial PRIMARY KEY,
  platform bigint NOT NULL REFERENCES platforms (platform_id),
  sensor bigint NOT NULL REFERENCES sensors (sensor_id),
  stamp_ns bigint NOT NULL,
  file_id bigint NOT NULL REFERENCES files (file_id),
  "offset" bigint NOT NULL CHECK ("offset" >= 0),
  length bigint NOT NULL CHECK (length > 0),
  type text NOT NULL
);
CREATE INDEX data_by_platform_sensor_stamp ON data (platform, sensor, stamp_ns);
CREATE UNIQUE INDEX data_by_file_offset ON data (file_id, "offset");
