-- Schema 4: annotations on data of the sensor index and typed payload tables (seed 000 §4.2,
-- §5.2; annotation_store.h). Logically the same as sqlite/migrations/0004_annotations.sql
-- (see there for the reasoning).
ALTER TABLE annotations ADD COLUMN data_id bigint REFERENCES data (data_id);
-- The unnamed CHECK of schema 1 is "annotations_check" (PostgreSQL's naming rule).
ALTER TABLE annotations DROP CONSTRAINT annotations_check;
ALTER TABLE annotations ADD CONSTRAINT annotations_one_target
  CHECK (num_nonnulls(node_id, edge_id, parent_id, data_id) = 1);
CREATE INDEX annotations_by_datum ON annotations (data_id) WHERE data_id IS NOT NULL;

CREATE TABLE annotation_bbox2d (
  annotation_id uuid PRIMARY KEY REFERENCES annotations (id) ON DELETE CASCADE,
  x_px double precision NOT NULL,
  y_px double precision NOT NULL,
  width_px double precision NOT NULL CHECK (width_px > 0),
  height_px double precision NOT NULL CHECK (height_px > 0),
  label text NOT NULL CHECK (label <> ''),
  score double precision NOT NULL CHECK (score >= 0 AND score <= 1)
);
CREATE INDEX annotation_bbox2d_by_label ON annotation_bbox2d (label);

CREATE TABLE annotation_datum_link (
  annotation_id uuid PRIMARY KEY REFERENCES annotations (id) ON DELETE CASCADE,
  data_id bigint NOT NULL REFERENCES data (data_id)
);
CREATE INDEX annotation_datum_link_by_datum ON annotation_datum_link (data_id);
