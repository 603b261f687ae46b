#include "repository_arguments.h"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>

#include "fleetmap/core/error.h"

namespace fleetmap::cli {

void AddStoreOption(CLI::App& command, std::string& uri) {
  uri = kDefaultStore;
  command
      .add_option("--store", uri,
                  "The repository: sqlite:PATH or postgresql://USER[:PASSWORD]@HOST:PORT/DB")
      ->capture_default_str();
}

std::string SqlitePath(std::string_view uri) {
  constexpr std::string_view kScheme = "sqlite:";
  if (!uri.starts_with(kScheme)) return "";
  std::string_view path = uri.substr(kScheme.size());
  if (path.starts_with("//")) path.remove_prefix(2);  // as GraphStore::Open reads it
  return std::string(path);
}

namespace {

// Refuses an SQLite repository file that does not exist (OpenRepository).
void RequireRepositoryFile(const std::string& uri) {
  const std::string path = SqlitePath(uri);
  if (!path.empty() && !std::filesystem::exists(path)) {
    throw Error(ErrorCode::kNotFound, "no repository at " + uri + " (" + path +
                                          " does not exist); create one with `fleetmap init "
                                          "--store " +
                                          uri + "`");
  }
}

}  // namespace

std::unique_ptr<Repository> OpenRepository(const std::string& uri, bool create) {
  if (!create) RequireRepositoryFile(uri);
  return Repository::Open(uri);
}

std::unique_ptr<GraphStore> OpenRepositoryStore(const std::string& uri) {
  RequireRepositoryFile(uri);
  return GraphStore::Open(uri);
}

std::unique_ptr<Repository> OpenExistingRepository(const std::string& uri) {
  RepositoryOptions options;
  options.store.create_if_missing = false;
  try {
    return Repository::Open(uri, options);
  } catch (const Error& error) {
    // The store says "URI is not a fleetmap map store (why)", which reads best as it is.
    if (error.message().find(" is not a fleetmap map store (") != std::string::npos) {
      throw Error(error.code(), "--store " + error.message());
    }
    throw InContext(error, "--store " + uri + " cannot be read");
  }
}

Uuid ParseUuidArgument(std::string_view text, std::string_view what) {
  try {
    return Uuid::Parse(text);
  } catch (const Error&) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(what) + " '" + std::string(text) +
                    "' is not a UUID (expected xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx)");
  }
}

void RequireRevision(Repository& repository, RevisionNumber r) {
  const RevisionNumber head = repository.Head();
  if (r < 0 || r > head) {
    throw Error(ErrorCode::kNotFound, "no revision " + std::to_string(r) + " in " +
                                          repository.uri() +
                                          ": its revisions run from 0 (the empty map) to " +
                                          std::to_string(head) + " (the head)");
  }
}

std::string FormatUtc(std::int64_t ns) {
  // Floor division, so times before 1970 still print the right second.
  std::int64_t seconds = ns / 1'000'000'000;
  if (ns % 1'000'000'000 < 0) --seconds;
  const std::time_t t = static_cast<std::time_t>(seconds);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::int64_t ParseUtcTime(const std::string& text, std::string_view option) {
  auto bad = [&] {
    return Error(ErrorCode::kInvalidArgument,
                 std::string(option) + " '" + text +
                     "' is neither UTC nanoseconds nor ISO 8601 like 2014-06-02T09:30:15.25Z");
  };
  if (text.empty()) throw bad();
  std::size_t i = text[0] == '-' ? 1 : 0;
  if (i < text.size() && text.find_first_not_of("0123456789", i) == std::string::npos) {
    try {
      return std::stoll(text);
    } catch (const std::exception&) {
      throw bad();
    }
  }
  std::tm tm{};
  int consumed = 0;
  if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                  &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &consumed) != 6) {
    throw bad();
  }
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  std::int64_t fraction_ns = 0;
  std::size_t pos = static_cast<std::size_t>(consumed);
  if (pos < text.size() && text[pos] == '.') {
    std::int64_t scale = 100'000'000;
    for (++pos; pos < text.size() && std::isdigit(static_cast<unsigned char>(text[pos])); ++pos) {
      fraction_ns += (text[pos] - '0') * scale;
      scale /= 10;
    }
  }
  if (pos + 1 != text.size() || text[pos] != 'Z') throw bad();
  return static_cast<std::int64_t>(timegm(&tm)) * 1'000'000'000 + fraction_ns;
}

Error InContext(const Error& error, const std::string& context) {
  return Error(error.code(), context + ": " + error.message());
}

std::string Count(std::int64_t n, std::string_view one, std::string_view many) {
  std::string text = std::to_string(n) + " ";
  if (n == 1) return text.append(one);
  if (many.empty()) return text.append(one).append("s");
  return text.append(many);
}

std::string DefaultAuthor() {
  const char* user = std::getenv("USER");
  return user != nullptr && *user != '\0' ? user : "fleetmap";
}

}  // namespace fleetmap::cli
