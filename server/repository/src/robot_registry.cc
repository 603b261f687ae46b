#include "fleetmap/repository/robot_registry.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <algorithm>
#include <array>
#include <nlohmann/json.hpp>

#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

constexpr std::string_view kRobotPrefix = "robot/";
constexpr std::string_view kSyncPrefix = "robot-sync/";
constexpr std::string_view kSentPrefix = "robot-sent/";
constexpr std::string_view kInstalledPrefix = "robot-map/";
constexpr std::string_view kErrorPrefix = "robot-error/";
constexpr std::size_t kMaxErrorBytes = 500;
constexpr std::size_t kTokenBytes = 32;
constexpr std::size_t kSaltBytes = 16;
constexpr std::size_t kMaxNameLength = 64;

std::string Hex(const unsigned char* data, std::size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  text.reserve(2 * size);
  for (std::size_t i = 0; i < size; ++i) {
    text.push_back(kDigits[data[i] >> 4]);
    text.push_back(kDigits[data[i] & 0xf]);
  }
  return text;
}

std::string RandomHex(std::size_t bytes) {
  std::vector<unsigned char> random(bytes);
  if (RAND_bytes(random.data(), static_cast<int>(random.size())) != 1) {
    throw Error(ErrorCode::kBackend, "robot registry: OpenSSL RAND_bytes found no randomness");
  }
  return Hex(random.data(), random.size());
}

// SHA-256 over salt then token, as hex.
std::string SaltedHash(std::string_view salt, std::string_view token) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  EVP_MD_CTX* context = EVP_MD_CTX_new();
  const bool ok = context != nullptr && EVP_DigestInit_ex(context, EVP_sha256(), nullptr) == 1 &&
                  EVP_DigestUpdate(context, salt.data(), salt.size()) == 1 &&
                  EVP_DigestUpdate(context, token.data(), token.size()) == 1 &&
                  EVP_DigestFinal_ex(context, digest.data(), &length) == 1;
  EVP_MD_CTX_free(context);
  if (!ok) throw Error(ErrorCode::kBackend, "robot registry: OpenSSL SHA-256 failed");
  return Hex(digest.data(), length);
}

std::string RobotKey(const Uuid& robot) {
  return std::string(kRobotPrefix) + robot.ToString();
}
std::string SyncKey(const Uuid& robot) {
  return std::string(kSyncPrefix) + robot.ToString();
}

std::string KeyOf(std::string_view prefix, const Uuid& robot) {
  return std::string(prefix) + robot.ToString();
}

std::string RobotMapJson(const RobotMapRecord& map) {
  // The digest as text: JSON numbers past 2^53 do not survive every reader.
  return JsonText(nlohmann::json{{"channel", map.channel},
                                 {"revision", map.revision},
                                 {"digest", std::to_string(map.digest)},
                                 {"at_ns", map.at_ns}});
}

std::optional<RobotMapRecord> ParseRobotMap(const std::optional<std::string>& value) {
  if (!value) return std::nullopt;
  try {
    const nlohmann::json json = nlohmann::json::parse(*value);
    RobotMapRecord map;
    map.channel = json.at("channel").get<std::string>();
    map.revision = json.at("revision").get<std::int64_t>();
    map.digest = std::stoull(json.at("digest").get<std::string>());
    map.at_ns = json.at("at_ns").get<std::int64_t>();
    return map;
  } catch (const std::exception& error) {
    // A damaged report is not worth failing a listing over: it reads as none.
    return std::nullopt;
  }
}

// Authenticate's stand-in for a robot that is not registered: shaped as a real record, with a
// "hash" that is not hex, so that no token's hash equals it.
constexpr std::string_view kUnknownRobotRecord =
    R"({"name":"","salt":"00000000000000000000000000000000",)"
    R"("hash":"----------------------------------------------------------------",)"
    R"("added_ns":0})";

struct StoredRobot {
  RegisteredRobot robot;
  std::string salt;
  std::string hash;
};

StoredRobot ParseStored(const std::string& key, std::string_view value) {
  try {
    const nlohmann::json json = nlohmann::json::parse(value.begin(), value.end());
    StoredRobot stored;
    stored.robot.id = Uuid::Parse(key.substr(kRobotPrefix.size()));
    stored.robot.name = json.at("name").get<std::string>();
    stored.robot.added_ns = json.at("added_ns").get<std::int64_t>();
    stored.salt = json.at("salt").get<std::string>();
    stored.hash = json.at("hash").get<std::string>();
    return stored;
  } catch (const nlohmann::json::exception& error) {
    throw Error(ErrorCode::kCorrupt, "robot registry: setting " + key + ": " + error.what());
  }
}

void CheckName(std::string_view name) {
  const bool printable = std::all_of(name.begin(), name.end(), [](char c) {
    return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
  });
  if (name.empty() || name.size() > kMaxNameLength || !printable || name.front() == ' ' ||
      name.back() == ' ') {
    throw Error(ErrorCode::kInvalidArgument,
                "robot name '" + std::string(name) +
                    "': use 1 to 64 printable characters without leading or trailing spaces");
  }
}

}  // namespace

NewRobot RobotRegistry::Add(std::string_view name, std::int64_t now_ns) {
  CheckName(name);
  for (const RegisteredRobot& robot : List()) {
    if (robot.name == name) {
      throw Error(ErrorCode::kConflict, "a robot named '" + std::string(name) +
                                            "' is registered already (" + robot.id.ToString() +
                                            ")");
    }
  }
  NewRobot added;
  added.robot.id = Uuid::GenerateRandom();
  added.robot.name = std::string(name);
  added.robot.added_ns = now_ns;
  added.token = RandomHex(kTokenBytes);
  const std::string salt = RandomHex(kSaltBytes);
  const nlohmann::json json = {{"name", added.robot.name},
                               {"salt", salt},
                               {"hash", SaltedHash(salt, added.token)},
                               {"added_ns", now_ns}};
  versions_.PutSetting(RobotKey(added.robot.id), JsonText(json));
  return added;
}

RobotAuthenticationResult RobotRegistry::Authenticate(const Uuid& robot, std::string_view token) {
  RobotAuthenticationResult result;
  const std::optional<std::string> value = versions_.FindSetting(RobotKey(robot));
  // An unknown robot costs what a known one does (a record parsed, the token hashed and
  // compared, against a stand-in no token matches), so the time of the answer does not tell a
  // stranger which ids are registered.
  const StoredRobot stored = ParseStored(RobotKey(robot), value ? *value : kUnknownRobotRecord);
  const std::string hash = SaltedHash(stored.salt, token);
  // Both are hex SHA-256 (64 characters) unless the store is damaged; compare in constant
  // time so the answer's timing says nothing about how much of the token was right.
  const bool match = hash.size() == stored.hash.size() &&
                     CRYPTO_memcmp(hash.data(), stored.hash.data(), hash.size()) == 0;
  if (!value) {
    result.outcome = RobotAuthentication::kUnknownRobot;
    return result;
  }
  if (!match) {
    result.outcome = RobotAuthentication::kBadToken;
    return result;
  }
  result.outcome = RobotAuthentication::kAccepted;
  result.robot = stored.robot;
  if (const std::optional<std::string> sync = versions_.FindSetting(SyncKey(robot))) {
    result.robot->last_sync_ns = std::stoll(*sync);
  }
  return result;
}

std::vector<RegisteredRobot> RobotRegistry::List() {
  std::vector<RegisteredRobot> robots;
  for (const auto& [key, value] : versions_.ListSettings(kRobotPrefix)) {
    robots.push_back(ParseStored(key, value).robot);
  }
  for (RegisteredRobot& robot : robots) AddActivity(robot);
  std::sort(robots.begin(), robots.end(),
            [](const RegisteredRobot& a, const RegisteredRobot& b) { return a.name < b.name; });
  return robots;
}

std::optional<RegisteredRobot> RobotRegistry::Find(const Uuid& robot) {
  const std::optional<std::string> value = versions_.FindSetting(RobotKey(robot));
  if (!value) return std::nullopt;
  RegisteredRobot found = ParseStored(RobotKey(robot), *value).robot;
  AddActivity(found);
  return found;
}

void RobotRegistry::RecordSync(const Uuid& robot, std::int64_t now_ns) {
  versions_.PutSetting(SyncKey(robot), std::to_string(now_ns));
}

void RobotRegistry::AddActivity(RegisteredRobot& robot) {
  if (const std::optional<std::string> sync = versions_.FindSetting(SyncKey(robot.id))) {
    robot.last_sync_ns = std::stoll(*sync);
  }
  robot.sent = ParseRobotMap(versions_.FindSetting(KeyOf(kSentPrefix, robot.id)));
  robot.installed = ParseRobotMap(versions_.FindSetting(KeyOf(kInstalledPrefix, robot.id)));
  if (const std::optional<std::string> error =
          versions_.FindSetting(KeyOf(kErrorPrefix, robot.id))) {
    const std::size_t space = error->find(' ');
    if (space != std::string::npos) {
      robot.last_error_ns = std::stoll(error->substr(0, space));
      robot.last_error = error->substr(space + 1);
    }
  }
}

void RobotRegistry::RecordSent(const Uuid& robot, const RobotMapRecord& sent) {
  versions_.PutSetting(KeyOf(kSentPrefix, robot), RobotMapJson(sent));
}

void RobotRegistry::RecordInstalled(const Uuid& robot, const RobotMapRecord& installed) {
  versions_.PutSetting(KeyOf(kInstalledPrefix, robot), RobotMapJson(installed));
}

void RobotRegistry::RecordError(const Uuid& robot, std::string_view error, std::int64_t now_ns) {
  versions_.PutSetting(KeyOf(kErrorPrefix, robot),
                       std::to_string(now_ns) + " " + ReceivedText(error, kMaxErrorBytes));
}

}  // namespace fleetmap
