// What the repository commands (init, push, merge, log, checkout, download, dream, ...) share:
// the --store option, opening the repository it names, and reading and printing the things
// people type and read: UUIDs, revision numbers, UTC timestamps (times of day:
// fleetmap/core/clock.h).
// Every parse failure throws fleetmap::Error naming the option and the text given.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap::cli {

inline constexpr const char* kDefaultStore = "sqlite:fleetmap.db";

// Adds --store URI (default kDefaultStore) to `command`.
void AddStoreOption(CLI::App& command, std::string& uri);

// Opens the repository at `uri`. Unless `create`, an SQLite file that does not exist is
// refused with Error(kNotFound) pointing at `fleetmap init`, so a mistyped path does not
// quietly become an empty repository. (A PostgreSQL database has to exist to be connected to.)
std::unique_ptr<Repository> OpenRepository(const std::string& uri, bool create = false);

// The store of the repository at `uri`, refused as OpenRepository refuses it, for commands on
// what the store keeps beside the repository's history: raw sensor data and its annotations.
std::unique_ptr<GraphStore> OpenRepositoryStore(const std::string& uri);

// The repository at `uri`, which must exist already, for a command that only reads (`export`,
// `render`): an empty file or another program's database is refused as it is ("--store URI is
// not a fleetmap map store (why)"), not migrated into an empty repository; any other failure
// to open it is named "--store URI cannot be read: why".
std::unique_ptr<Repository> OpenExistingRepository(const std::string& uri);

// The path of an `sqlite:PATH` (or sqlite://PATH) URI; empty for any other scheme.
std::string SqlitePath(std::string_view uri);

// Canonical UUID text; else Error(kInvalidArgument) "<what> 'text' is not a UUID ...".
Uuid ParseUuidArgument(std::string_view text, std::string_view what);

// Throws Error(kNotFound) unless 0 <= r <= the head, naming the revision, the store and the
// range of revisions there are.
void RequireRevision(Repository& repository, RevisionNumber r);

// UTC nanoseconds as ISO 8601 to the second: 2024-05-01T08:30:00Z.
std::string FormatUtc(std::int64_t ns);

// A time given as integer UTC nanoseconds or as ISO 8601 UTC, YYYY-MM-DDTHH:MM:SS[.fraction]Z;
// else Error(kInvalidArgument) naming `option` and the text.
std::int64_t ParseUtcTime(const std::string& text, std::string_view option);

// `error` with `context` in front of its message ("context: message"), same code. (Error's
// what() starts with the code's name; that is not repeated inside.)
Error InContext(const Error& error, const std::string& context);

// "1 path", "3 paths": n and the noun, plural unless n is 1 (`many` defaults to one + "s").
std::string Count(std::int64_t n, std::string_view one, std::string_view many = {});

// The author of a command run by a person: $USER, else "fleetmap".
std::string DefaultAuthor();

}  // namespace fleetmap::cli
