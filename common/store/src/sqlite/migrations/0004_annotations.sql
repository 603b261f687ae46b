-- Schema 4: annotations on data of the sensor index and typed payload tables (seed 000 §4.2,
-- §5.2; annotation_store.h). Logically the same as postgres/migrations/0004_annotations.sql.
--
-- Seed 000 §5.2 keeps annotations in ONE global table and annotation-specific data in tables
-- of their own. The global table of schema 1 gains data_id, and "exactly one target" now
-- counts it too. SQLite cannot change a CHECK in place, so the table is rebuilt: the copy
-- refers to itself by its new name, which RENAME rewrites to "annotations" (SQLite >= 3.26),
-- so dropping the old table never trips the parent foreign key of the copied rows.
CREATE TABLE annotations_v4 (
  seq INTEGER PRIMARY KEY,
  id BLOB NOT NULL UNIQUE CHECK (length(id) = 16),
  node_id BLOB REFERENCES nodes (id),
  edge_id BLOB REFERENCES edges (id),
  parent_id BLOB REFERENCES annotations_v4 (id),
  type TEXT NOT NULL,
  payload BLOB NOT NULL,
  data_id INTEGER REFERENCES data (data_id),
  CHECK ((node_id IS NOT NULL) + (edge_id IS NOT NULL) + (parent_id IS NOT NULL)
         + (data_id IS NOT NULL) = 1)
);
INSERT INTO annotations_v4 (seq, id, node_id, edge_id, parent_id, type, payload)
  SELECT seq, id, node_id, edge_id, parent_id, type, payload FROM annotations;
DROP TABLE annotations;
ALTER TABLE annotations_v4 RENAME TO annotations;
CREATE INDEX annotations_by_node ON annotations (node_id) WHERE node_id IS NOT NULL;
CREATE INDEX annotations_by_edge ON annotations (edge_id) WHERE edge_id IS NOT NULL;
CREATE INDEX annotations_by_parent ON annotations (parent_id) WHERE parent_id IS NOT NULL;
CREATE INDEX annotations_by_datum ON annotations (data_id) WHERE data_id IS NOT NULL;

-- Typed payload "bbox2d": an axis-aligned box in image pixels with a label and a score.
-- Deleting the annotation deletes its box.
CREATE TABLE annotation_bbox2d (
  annotation_id BLOB PRIMARY KEY NOT NULL REFERENCES annotations (id) ON DELETE CASCADE,
  x_px REAL NOT NULL,
  y_px REAL NOT NULL,
  width_px REAL NOT NULL CHECK (width_px > 0),
  height_px REAL NOT NULL CHECK (height_px > 0),
  label TEXT NOT NULL CHECK (label <> ''),
  score REAL NOT NULL CHECK (score >= 0 AND score <= 1)
) WITHOUT ROWID;
CREATE INDEX annotation_bbox2d_by_label ON annotation_bbox2d (label);

-- Typed payload "datum_link": links the node or edge the annotation is on to a datum (e.g.
-- the image an experience was built from), so the map and the raw data reach each other
-- (seed 000 §4.3.1). Both ends are foreign keys.
CREATE TABLE annotation_datum_link (
  annotation_id BLOB PRIMARY KEY NOT NULL REFERENCES annotations (id) ON DELETE CASCADE,
  data_id INTEGER NOT NULL REFERENCES data (data_id)
) WITHOUT ROWID;
CREATE INDEX annotation_datum_link_by_datum ON annotation_datum_link (data_id);
