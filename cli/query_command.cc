// `fleetmap query ...`: the seed 000 §4.1 queries over the sensor index (sensor_index.h):
//   datum ID                      one Data row by data_id
//   nearest                       Ω̄(r, s, t), Eq. 1 (before / after / closest, tolerance)
//   join                          Ω(r, t), Eq. 2: the nearest datum of every mounted sensor
//   batch-join                    every datum of one sensor in [from, to] with the nearest of
//                                 each other sensor, streamed (JSON Lines with --json)
// Times are UTC nanoseconds or ISO 8601 (2014-06-02T09:30:15.25Z).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct QueryArgs {
  std::string store;
  bool json = false;
  std::int64_t id = 0;
  std::string platform;
  std::string sensor;
  std::string at;
  std::string from;
  std::string to;
  std::string mode = "closest";
  std::optional<double> tolerance_ms;
};

NearestQuery ParseQuery(const QueryArgs& args) {
  NearestQuery q;
  if (args.mode == "before") {
    q.mode = NearestMode::kBefore;
  } else if (args.mode == "after") {
    q.mode = NearestMode::kAfter;
  } else {
    q.mode = NearestMode::kClosest;
  }
  if (args.tolerance_ms) q.tolerance_ns = static_cast<std::int64_t>(*args.tolerance_ms * 1e6);
  return q;
}

PlatformId PlatformNamed(SensorIndex& index, const std::string& name) {
  if (auto p = index.FindPlatform(name)) return p->id;
  throw Error(ErrorCode::kNotFound, "no platform '" + name + "' in the index");
}

SensorId SensorNamed(SensorIndex& index, const std::string& name) {
  if (auto s = index.FindSensor(name)) return s->id;
  throw Error(ErrorCode::kNotFound, "no sensor '" + name + "' in the index");
}

// Names of platforms and sensors, looked up once each.
class Names {
 public:
  explicit Names(SensorIndex& index) : index_(index) {}
  const std::string& Platform(PlatformId id) { return Lookup(platforms_, id, true); }
  const std::string& Sensor(SensorId id) { return Lookup(sensors_, id, false); }

 private:
  const std::string& Lookup(std::map<std::int64_t, std::string>& cache, std::int64_t id,
                            bool platform) {
    auto it = cache.find(id);
    if (it == cache.end()) {
      it = cache.emplace(id, platform ? index_.GetPlatform(id).name : index_.GetSensor(id).name)
               .first;
    }
    return it->second;
  }
  SensorIndex& index_;
  std::map<std::int64_t, std::string> platforms_, sensors_;
};

// UTC to the millisecond: sensor data are often milliseconds apart.
std::string TimeText(std::int64_t ns) {
  std::string text = FormatUtc(ns);  // ...SSZ
  std::int64_t ms = (ns / 1'000'000) % 1000;
  if (ms < 0) ms += 1000;
  char fraction[8];
  std::snprintf(fraction, sizeof fraction, ".%03lld", static_cast<long long>(ms));
  text.insert(text.size() - 1, fraction);
  return text;
}

nlohmann::json DatumJson(const Datum& d, Names& names) {
  return {{"data_id", d.id},
          {"platform", names.Platform(d.platform)},
          {"sensor", names.Sensor(d.sensor)},
          {"stamp_ns", d.stamp_ns},
          {"time", TimeText(d.stamp_ns)},
          {"file", d.file},
          {"offset", d.offset},
          {"length", d.length},
          {"type", d.type}};
}

void PrintHeader() {
  std::printf("%-10s %-12s %-12s %-20s %-25s %-10s %-8s %s\n", "data_id", "platform", "sensor",
              "stamp_ns", "time", "offset", "length", "file / type");
}

void PrintDatum(const Datum& d, Names& names) {
  std::printf("%-10lld %-12s %-12s %-20lld %-25s %-10llu %-8llu %s  %s\n",
              static_cast<long long>(d.id), names.Platform(d.platform).c_str(),
              names.Sensor(d.sensor).c_str(), static_cast<long long>(d.stamp_ns),
              TimeText(d.stamp_ns).c_str(), static_cast<unsigned long long>(d.offset),
              static_cast<unsigned long long>(d.length), d.file.c_str(), d.type.c_str());
}

void PrintData(const std::vector<Datum>& data, bool json, Names& names) {
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const Datum& d : data) out.push_back(DatumJson(d, names));
    std::cout << JsonText(out, 2) << "\n";
    return;
  }
  PrintHeader();
  for (const Datum& d : data) PrintDatum(d, names);
}

void RunDatum(const QueryArgs& args) {
  auto store = GraphStore::Open(args.store);
  Names names(store->sensors());
  const Datum d = store->sensors().GetDatum(args.id);
  if (args.json) {
    std::cout << JsonText(DatumJson(d, names), 2) << "\n";
  } else {
    PrintData({d}, false, names);
  }
}

void RunNearest(const QueryArgs& args) {
  auto store = GraphStore::Open(args.store);
  SensorIndex& index = store->sensors();
  Names names(index);
  const std::int64_t t = ParseUtcTime(args.at, "--at");
  const std::optional<Datum> d = index.Nearest(
      PlatformNamed(index, args.platform), SensorNamed(index, args.sensor), t, ParseQuery(args));
  if (!d) {
    if (args.json) std::cout << "null\n";
    throw Error(ErrorCode::kNotFound, "no datum of sensor '" + args.sensor + "' on platform '" +
                                          args.platform + "' " + args.mode + " " + args.at +
                                          (args.tolerance_ms ? " within the tolerance" : ""));
  }
  PrintData({*d}, args.json, names);
}

void RunJoin(const QueryArgs& args) {
  auto store = GraphStore::Open(args.store);
  SensorIndex& index = store->sensors();
  Names names(index);
  const std::int64_t t = ParseUtcTime(args.at, "--at");
  PrintData(index.TemporalJoin(PlatformNamed(index, args.platform), t, ParseQuery(args)), args.json,
            names);
}

void RunBatchJoin(const QueryArgs& args) {
  auto store = GraphStore::Open(args.store);
  SensorIndex& index = store->sensors();
  Names names(index);
  const std::int64_t t0 = ParseUtcTime(args.from, "--from");
  const std::int64_t t1 = ParseUtcTime(args.to, "--to");
  const PlatformId platform = PlatformNamed(index, args.platform);
  const SensorId base = SensorNamed(index, args.sensor);
  std::vector<SensorId> others;
  bool header = false;
  const std::int64_t rows = index.BatchTemporalJoin(
      platform, base, t0, t1,
      [&](const JoinedRow& row) {
        if (args.json) {
          // JSON Lines: one object per base datum, so the output streams like the join.
          nlohmann::json line = {{"base", DatumJson(row.base, names)}};
          nlohmann::json matched = nlohmann::json::object();
          for (std::size_t i = 0; i < others.size(); ++i) {
            matched[names.Sensor(others[i])] =
                row.others[i] ? DatumJson(*row.others[i], names) : nlohmann::json(nullptr);
          }
          line["others"] = matched;
          std::cout << JsonText(line) << "\n";
          return;
        }
        if (!header) {
          std::printf("%-20s %-10s", "base stamp_ns", "base id");
          for (SensorId s : others)
            std::printf(" %-24s", (names.Sensor(s) + " id (dt ms)").c_str());
          std::printf("\n");
          header = true;
        }
        std::printf("%-20lld %-10lld", static_cast<long long>(row.base.stamp_ns),
                    static_cast<long long>(row.base.id));
        for (const std::optional<Datum>& o : row.others) {
          if (!o) {
            std::printf(" %-24s", "-");
            continue;
          }
          char cell[64];
          std::snprintf(cell, sizeof cell, "%lld (%+.3f)", static_cast<long long>(o->id),
                        static_cast<double>(o->stamp_ns - row.base.stamp_ns) / 1e6);
          std::printf(" %-24s", cell);
        }
        std::printf("\n");
      },
      ParseQuery(args), &others);
  if (!args.json) std::printf("%lld row(s)\n", static_cast<long long>(rows));
}

void AddCommon(CLI::App& command, QueryArgs& args) {
  AddStoreOption(command, args.store);
  command.add_flag("--json", args.json, "Print JSON");
}

void AddNearestOptions(CLI::App& command, QueryArgs& args) {
  command.add_option("--mode", args.mode, "before | after | closest")
      ->check(CLI::IsMember({"before", "after", "closest"}))
      ->capture_default_str();
  command.add_option("--tolerance-ms", args.tolerance_ms,
                     "No match further than this from the time (milliseconds)");
}

}  // namespace

void AddQueryCommand(CLI::App& app) {
  CLI::App* query = app.add_subcommand("query", "Query the sensor index (seed 000 Eqs. 1-2)");
  query->require_subcommand(1);

  auto datum_args = std::make_shared<QueryArgs>();
  CLI::App* datum = query->add_subcommand("datum", "One datum by data_id");
  datum->add_option("id", datum_args->id, "The data_id")->required();
  AddCommon(*datum, *datum_args);
  datum->callback([datum_args] { RunDatum(*datum_args); });

  auto nearest_args = std::make_shared<QueryArgs>();
  CLI::App* nearest = query->add_subcommand(
      "nearest", "The datum of a platform's sensor nearest to a time (Eq. 1)");
  nearest->add_option("--platform", nearest_args->platform, "Platform name")->required();
  nearest->add_option("--sensor", nearest_args->sensor, "Sensor name")->required();
  nearest->add_option("--at", nearest_args->at, "Time: UTC ns or ISO 8601")->required();
  AddNearestOptions(*nearest, *nearest_args);
  AddCommon(*nearest, *nearest_args);
  nearest->callback([nearest_args] { RunNearest(*nearest_args); });

  auto join_args = std::make_shared<QueryArgs>();
  CLI::App* join = query->add_subcommand(
      "join",
      "The world as a platform saw it at a time: every mounted sensor's nearest datum "
      "(Eq. 2)");
  join->add_option("--platform", join_args->platform, "Platform name")->required();
  join->add_option("--at", join_args->at, "Time: UTC ns or ISO 8601")->required();
  AddNearestOptions(*join, *join_args);
  AddCommon(*join, *join_args);
  join->callback([join_args] { RunJoin(*join_args); });

  auto batch_args = std::make_shared<QueryArgs>();
  CLI::App* batch = query->add_subcommand(
      "batch-join",
      "Every datum of one sensor in a time range joined to the nearest datum of each other "
      "sensor of the platform (streamed; --json prints JSON Lines)");
  batch->add_option("--platform", batch_args->platform, "Platform name")->required();
  batch->add_option("--sensor", batch_args->sensor, "The base sensor")->required();
  batch->add_option("--from", batch_args->from, "Range start: UTC ns or ISO 8601")->required();
  batch->add_option("--to", batch_args->to, "Range end (inclusive)")->required();
  AddNearestOptions(*batch, *batch_args);
  AddCommon(*batch, *batch_args);
  batch->callback([batch_args] { RunBatchJoin(*batch_args); });
}

}  // namespace fleetmap::cli
