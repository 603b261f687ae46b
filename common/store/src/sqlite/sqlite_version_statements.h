// The SQLite VersionStore's prepared statements (schema in migrations/0002_versions.sql) and
// the readers of the rows they select. sqlite_version_store.cc runs them: that file says what
// the store does, this one what it asks SQLite.
#pragma once

#include <sqlite3.h>

#include "fleetmap/store/version_store.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

// Elements per statement in AppendRevision: SQLite sets up a statement (a cursor on every
// index it touches) each time it runs, and 32 elements pay that once instead of 32 times
// (as the graph store's batch inserts do); AppendRevision of 10^5 elements takes about as
// long as their Put.
constexpr int kElementsPerStatement = 32;

// A submission and its chunks (0002_versions.sql), and its merge's claim
// (0006_submission_claims.sql).
struct SubmissionStatements {
  explicit SubmissionStatements(sqlite3* db);
  Statement begin_submission, find_submission, list_submissions, chunk_equals, insert_chunk,
      count_chunk, chunk, complete_submission, set_submission_state, first_claimable, set_claim,
      renew_claim, release_claim, find_claim;
};

// Revisions, and what each adds and hides (element_versions).
struct RevisionStatements {
  explicit RevisionStatements(sqlite3* db);
  Statement head, find_revision, list_revisions, reverted_by, insert_revision, set_hidden_counts,
      stored_among, add_elements, add_element, hide_added, hide_node, hide_touching_versioned,
      hide_touching_unversioned, hidden_counts;
};

// A revision read back: what it shows, what changed between two, one element's version.
struct CheckoutStatements {
  explicit CheckoutStatements(sqlite3* db);
  Statement nodes_at, nodes_at_bare, edges_at, paths_at, stats_at, changed_between, version_of;
};

// Retirement (0009_retirement.sql).
struct RetirementStatements {
  explicit RetirementStatements(sqlite3* db);
  Statement any_retirement, retire_node, retire_touching, retired_counts, restore_retired,
      restored_counts, set_added_counts, retired_between, retirements_of;
};

// What merges record beside revisions: node usage, settings, submissions' nodes, stand-ins.
struct RecordStatements {
  explicit RecordStatements(sqlite3* db);
  Statement put_node_usage, usage_at, find_setting, put_setting, insert_setting_if_absent,
      replace_setting, list_settings, put_submission_node, submissions_with_node, put_stand_in,
      find_stand_in, stand_ins_of;
};

// Every statement the SQLite VersionStore runs, prepared once on its connection, by concern.
// REQUIRES: destroyed before the connection is closed.
struct SqliteVersionStatements : SubmissionStatements,
                                 RevisionStatements,
                                 CheckoutStatements,
                                 RetirementStatements,
                                 RecordStatements {
  explicit SqliteVersionStatements(sqlite3* db);
};

// A row of find_submission, list_submissions or submissions_with_node.
Submission ReadSubmission(const Statement& s);
// A row of find_revision or list_revisions.
Revision ReadRevision(const Statement& s);

}  // namespace fleetmap::internal
