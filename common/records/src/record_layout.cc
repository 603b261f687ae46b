// The platform/sensor/date layout of record files (record_layout.h).
#include "fleetmap/records/record_layout.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Splits nanoseconds since the epoch into a UTC calendar date and time of day. Floors, so a
// stamp before 1970 lands in the right second too.
struct UtcTime {
  int year;
  unsigned month, day, hour, minute, second;
};

UtcTime ToUtc(std::int64_t stamp_ns) {
  using namespace std::chrono;
  const sys_time<nanoseconds> t{nanoseconds{stamp_ns}};
  const sys_days day = floor<days>(t);
  const year_month_day ymd{day};
  const hh_mm_ss<seconds> time{floor<seconds>(t) - day};
  return {static_cast<int>(ymd.year()),
          static_cast<unsigned>(ymd.month()),
          static_cast<unsigned>(ymd.day()),
          static_cast<unsigned>(time.hours().count()),
          static_cast<unsigned>(time.minutes().count()),
          static_cast<unsigned>(time.seconds().count())};
}

}  // namespace

void CheckLayoutName(std::string_view name, std::string_view what) {
  const bool bad = name.empty() || name == "." || name == ".." ||
                   name.find_first_of(std::string_view("/\\\0", 3)) != std::string_view::npos;
  if (bad) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(what) + " name '" + std::string(name) +
                    "' cannot name a directory of the record layout (empty, '.', '..', or "
                    "holding '/', '\\\\' or NUL)");
  }
}

std::filesystem::path RecordFilePath(std::string_view platform, std::string_view sensor,
                                     std::int64_t stamp_ns) {
  CheckLayoutName(platform, "platform");
  CheckLayoutName(sensor, "sensor");
  const UtcTime t = ToUtc(stamp_ns);
  char date_dir[32];
  std::snprintf(date_dir, sizeof date_dir, "%04d-%02u-%02u", t.year, t.month, t.day);
  char stamp[32];
  std::snprintf(stamp, sizeof stamp, "%04d%02u%02u-%02u%02u%02u", t.year, t.month, t.day, t.hour,
                t.minute, t.second);
  const std::string p(platform);
  const std::string s(sensor);
  return std::filesystem::path(p) / s / date_dir / (p + "-" + s + "-" + stamp + ".rec");
}

std::filesystem::path RelativeToRoot(const std::filesystem::path& root,
                                     const std::filesystem::path& file) {
  std::filesystem::path r = std::filesystem::absolute(root).lexically_normal();
  if (!r.has_filename()) r = r.parent_path();  // a trailing '/' leaves an empty last element
  const std::filesystem::path f = std::filesystem::absolute(file).lexically_normal();
  std::filesystem::path relative = f.lexically_relative(r);
  // lexically_relative yields "" when there is no relation and "../x" when f is outside r.
  const bool outside = relative.empty() || relative == "." || *relative.begin() == "..";
  if (outside) {
    throw Error(ErrorCode::kInvalidArgument,
                "record file " + file.string() + " is not under the root " + root.string());
  }
  return relative;
}

std::filesystem::path ResolveUnderRoot(const std::filesystem::path& root,
                                       const std::filesystem::path& relative) {
  const std::filesystem::path normal = relative.lexically_normal();
  const bool outside =
      relative.empty() || relative.is_absolute() || normal == "." || *normal.begin() == "..";
  if (outside) {
    throw Error(ErrorCode::kInvalidArgument, "indexed path " + relative.string() +
                                                 " does not lie under the root " + root.string());
  }
  return root / normal;
}

std::optional<std::filesystem::path> LinkUnderRoot(const std::filesystem::path& root,
                                                   const std::filesystem::path& file) {
  namespace fs = std::filesystem;
  const fs::path relative = RelativeToRoot(root, file);
  fs::path on_the_way = root;
  for (const fs::path& part : relative) {
    on_the_way /= part;
    std::error_code ec;  // a component that does not exist is no link
    if (fs::is_symlink(fs::symlink_status(on_the_way, ec))) return on_the_way;
  }
  // "root/link/../x.rec" normalises to "root/x.rec", which the walk above finds free of links,
  // but opening it goes through the link's target. Where the file really is settles it.
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(file, ec);
  if (ec) return std::nullopt;  // nothing there to be led to
  const fs::path real_root = fs::weakly_canonical(root, ec);
  if (ec) return std::nullopt;
  if (real != (real_root / relative).lexically_normal()) return file;
  return std::nullopt;
}

}  // namespace fleetmap
