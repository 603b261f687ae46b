#include "fleetmap/repository/dream_candidates.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

constexpr std::string_view kRecordPrefix = "dream-candidate/";
constexpr std::string_view kContentPrefix = "dream-content/";

std::string RecordKey(const Uuid& id) {
  return std::string(kRecordPrefix) + id.ToString();
}

// Zero-padded, so the chunks of one candidate list in order.
std::string ContentKey(const Uuid& id, std::int64_t seq) {
  char number[24];
  std::snprintf(number, sizeof number, "%012lld", static_cast<long long>(seq));
  return std::string(kContentPrefix) + id.ToString() + "/" + number;
}

nlohmann::json UuidList(const std::vector<Uuid>& ids) {
  nlohmann::json list = nlohmann::json::array();
  for (const Uuid& id : ids) list.push_back(id.ToString());
  return list;
}

std::vector<Uuid> UuidsFrom(const nlohmann::json& list) {
  std::vector<Uuid> ids;
  for (const nlohmann::json& text : list) ids.push_back(Uuid::Parse(text.get<std::string>()));
  return ids;
}

}  // namespace

std::string DreamCandidateJson(const DreamCandidateRecord& r) {
  nlohmann::ordered_json json;
  json["id"] = r.id.ToString();
  json["created_ns"] = r.created_ns;
  json["base_revision"] = r.base_revision;
  json["dreamed_at_head"] = r.dreamed_at_head;
  json["groups"] = UuidList(r.groups);
  json["merged_order"] = UuidList(r.merged_order);
  json["held_out"] = {{"submission", r.held_out.ToString()},
                      {"rule", r.held_out_rule},
                      {"frames", r.held_out_frames}};
  json["orders"] = r.orders;
  json["score"] = {
      {"gap_m", r.gap_m},
      {"p_gap_exceeds", r.p_gap_exceeds},
      {"not_localised", r.not_localised},
      {"score", r.score},
      {"merged_order_score", r.merged_order_score ? nlohmann::ordered_json(*r.merged_order_score)
                                                  : nlohmann::ordered_json()}};
  json["content"] = {
      {"nodes", r.nodes}, {"edges", r.edges}, {"paths", r.paths}, {"chunks", r.chunks}};
  json["promoted_as"] = r.promoted_as;
  return JsonText(json);
}

DreamCandidateRecord DreamCandidateFromJson(std::string_view text) {
  try {
    const nlohmann::json json = nlohmann::json::parse(text);
    DreamCandidateRecord r;
    r.id = Uuid::Parse(json.at("id").get<std::string>());
    r.created_ns = json.at("created_ns").get<std::int64_t>();
    r.base_revision = json.at("base_revision").get<RevisionNumber>();
    r.dreamed_at_head = json.at("dreamed_at_head").get<RevisionNumber>();
    r.groups = UuidsFrom(json.at("groups"));
    r.merged_order = UuidsFrom(json.at("merged_order"));
    const nlohmann::json& held_out = json.at("held_out");
    r.held_out = Uuid::Parse(held_out.at("submission").get<std::string>());
    r.held_out_rule = held_out.at("rule").get<std::string>();
    r.held_out_frames = held_out.at("frames").get<std::size_t>();
    r.orders = json.at("orders").get<std::size_t>();
    const nlohmann::json& score = json.at("score");
    r.gap_m = score.at("gap_m").get<double>();
    r.p_gap_exceeds = score.at("p_gap_exceeds").get<double>();
    r.not_localised = score.at("not_localised").get<double>();
    r.score = score.at("score").get<double>();
    if (!score.at("merged_order_score").is_null()) {
      r.merged_order_score = score.at("merged_order_score").get<double>();
    }
    const nlohmann::json& content = json.at("content");
    r.nodes = content.at("nodes").get<std::int64_t>();
    r.edges = content.at("edges").get<std::int64_t>();
    r.paths = content.at("paths").get<std::int64_t>();
    r.chunks = content.at("chunks").get<std::int64_t>();
    r.promoted_as = json.at("promoted_as").get<RevisionNumber>();
    return r;
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kCorrupt, std::string("dream candidate record: ") + e.what());
  } catch (const Error& e) {
    throw Error(ErrorCode::kCorrupt, std::string("dream candidate record: ") + e.what());
  }
}

void RequireBeatsMergedOrder(const DreamCandidateRecord& record) {
  const std::string what = "dream candidate " + record.id.ToString();
  const std::string force = "`fleetmap promote --force` promotes it all the same";
  if (!record.merged_order_score) {
    throw Error(ErrorCode::kInvalidArgument,
                what + ": its dream did not score the order the server merged (it explored " +
                    std::to_string(record.orders) +
                    " orders), so it is not known to beat the map as merged; " + force);
  }
  if (record.score < *record.merged_order_score) return;
  // Six decimals: the candidates list's four can show a real difference as a tie.
  char scores[96];
  std::snprintf(scores, sizeof scores, "%.6f vs %.6f", record.score, *record.merged_order_score);
  throw Error(ErrorCode::kInvalidArgument,
              what + " does not beat the order the server merged: held-out score " + scores +
                  " (lower is better; " +
                  (record.score == *record.merged_order_score ? "a tie" : "worse") +
                  "), so promoting it would change the map for no gain; " + force);
}

DreamCandidateRecord DreamCandidates::Put(DreamCandidateRecord record, const GraphBatch& content) {
  if (record.id == Uuid()) record.id = Uuid::Generate();
  const std::vector<std::string> chunks = EncodeMapChunks(content);
  for (std::size_t seq = 0; seq < chunks.size(); ++seq) {
    versions_.PutSetting(ContentKey(record.id, static_cast<std::int64_t>(seq)), chunks[seq]);
  }
  record.nodes = static_cast<std::int64_t>(content.nodes.size());
  record.edges = static_cast<std::int64_t>(content.edges.size());
  record.paths = static_cast<std::int64_t>(content.paths.size());
  record.chunks = static_cast<std::int64_t>(chunks.size());
  versions_.PutSetting(RecordKey(record.id), DreamCandidateJson(record));
  return record;
}

std::vector<DreamCandidateRecord> DreamCandidates::List() {
  std::vector<DreamCandidateRecord> records;
  for (const auto& [key, value] : versions_.ListSettings(kRecordPrefix)) {
    records.push_back(DreamCandidateFromJson(value));
  }
  std::sort(records.begin(), records.end(), [](const auto& a, const auto& b) {
    return a.created_ns != b.created_ns ? a.created_ns > b.created_ns : a.id < b.id;
  });
  return records;
}

std::optional<DreamCandidateRecord> DreamCandidates::Find(const Uuid& id) {
  const std::optional<std::string> value = versions_.FindSetting(RecordKey(id));
  if (!value) return std::nullopt;
  return DreamCandidateFromJson(*value);
}

GraphBatch DreamCandidates::Content(const DreamCandidateRecord& record) {
  std::vector<std::string> chunks;
  for (std::int64_t seq = 0; seq < record.chunks; ++seq) {
    std::optional<std::string> chunk = versions_.FindSetting(ContentKey(record.id, seq));
    if (!chunk) {
      throw Error(ErrorCode::kCorrupt, "dream candidate " + record.id.ToString() +
                                           " is missing chunk " + std::to_string(seq) + " of " +
                                           std::to_string(record.chunks));
    }
    chunks.push_back(std::move(*chunk));
  }
  try {
    return DecodeMapChunks(chunks);
  } catch (const Error& e) {
    throw Error(ErrorCode::kCorrupt, "dream candidate " + record.id.ToString() + ": " + e.what());
  }
}

DreamCandidateRecord DreamCandidates::MarkPromoted(const Uuid& id, RevisionNumber revision) {
  // A failed replace means another promotion recorded first: read again, it names that one. (A
  // record is rewritten only by its promotion, so a second failure means a store changed
  // behind our back.)
  for (int attempt = 0; attempt < 2; ++attempt) {
    const std::optional<std::string> stored = versions_.FindSetting(RecordKey(id));
    if (!stored) {
      throw Error(ErrorCode::kNotFound,
                  "no dream candidate " + id.ToString() + " (`fleetmap candidates` lists them)");
    }
    DreamCandidateRecord record = DreamCandidateFromJson(*stored);
    RequireNotPromoted(record);
    record.promoted_as = revision;
    if (versions_.ReplaceSetting(RecordKey(id), stored, DreamCandidateJson(record))) return record;
  }
  throw Error(ErrorCode::kConflict, "dream candidate " + id.ToString() +
                                        " changed while it was being promoted: try again");
}

void RequireNotPromoted(const DreamCandidateRecord& record) {
  if (record.promoted_as != 0) {
    throw Error(ErrorCode::kConflict, "dream candidate " + record.id.ToString() +
                                          " is promoted already, as revision " +
                                          std::to_string(record.promoted_as));
  }
}

}  // namespace fleetmap
