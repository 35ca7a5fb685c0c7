#include "flatscan/store/station_record.h"

#include <cctype>
#include <chrono>
#include <regex>

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <openssl/rand.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using nlohmann::json;

std::string StringAt(const json& j, const char* key) {
  if (!j.contains(key) || !j.at(key).is_string())
    ThrowInputError("station record: key '{}' must be a string, found {}", key,
                    j.contains(key) ? j.at(key).dump() : "nothing");
  return j.at(key).get<std::string>();
}

}  // namespace

json StationRecordToJson(const StationRecord& r) {
  json j = RecordToJson(r.inspection);
  j["record_id"] = r.record_id;
  j["station_id"] = r.station_id;
  j["sequence"] = r.sequence;
  j["time_utc"] = r.time_utc;
  j["source_id"] = r.source_id;
  j["recipe"] = r.recipe_name;
  j["recipe_sha256"] = r.recipe_sha256;
  j["left_sha256"] = r.left_sha256;
  j["right_sha256"] = r.right_sha256;
  j["software_version"] = r.software_version;
  j["archive"] = r.archive.left.empty() ? json(nullptr) : json{{"left", r.archive.left}, {"right", r.archive.right}};
  if (!r.archive.thumbnail.empty()) j["archive"]["thumbnail"] = r.archive.thumbnail;
  if (!r.study.Empty())
    j["study"] = {{"part", r.study.part}, {"appraiser", r.study.appraiser}, {"trial", r.study.trial}};
  return j;
}

std::string StationRecordToJsonText(const StationRecord& record) {
  return StationRecordToJson(record).dump(-1, ' ', false, json::error_handler_t::replace);
}

StationRecord StationRecordFromJsonText(const std::string& text) {
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) ThrowInputError("its JSON cannot be parsed");
  return StationRecordFromJson(j);
}

StationRecord StationRecordFromJson(const json& j) {
  StationRecord r;
  r.inspection = RecordFromJson(j);
  r.record_id = StringAt(j, "record_id");
  r.station_id = StringAt(j, "station_id");
  if (!j.contains("sequence") || !j.at("sequence").is_number_integer())
    ThrowInputError("station record: key 'sequence' must be an integer");
  r.sequence = j.at("sequence").get<int64_t>();
  r.time_utc = StringAt(j, "time_utc");
  r.source_id = StringAt(j, "source_id");
  r.recipe_name = StringAt(j, "recipe");
  r.recipe_sha256 = StringAt(j, "recipe_sha256");
  r.left_sha256 = StringAt(j, "left_sha256");
  r.right_sha256 = StringAt(j, "right_sha256");
  r.software_version = StringAt(j, "software_version");
  if (j.contains("archive") && j.at("archive").is_object()) {
    r.archive.left = StringAt(j.at("archive"), "left");
    r.archive.right = StringAt(j.at("archive"), "right");
    if (j.at("archive").contains("thumbnail")) r.archive.thumbnail = StringAt(j.at("archive"), "thumbnail");
  }
  if (j.contains("study") && j.at("study").is_object())
    r.study = {StringAt(j.at("study"), "part"), StringAt(j.at("study"), "appraiser"), StringAt(j.at("study"), "trial")};
  return r;
}

std::string NewRecordId() {
  // 122 random bits from OpenSSL's generator (seeded by the kernel): two stations, or
  // two threads, never draw from the same seed.
  uint64_t bits[2] = {0, 0};
  FLATSCAN_CHECK(RAND_bytes(reinterpret_cast<unsigned char*>(bits), sizeof(bits)) == 1);
  const uint64_t hi = (bits[0] & 0xffffffffffff0fffULL) | 0x0000000000004000ULL;  // version 4
  const uint64_t lo = (bits[1] & 0x3fffffffffffffffULL) | 0x8000000000000000ULL;  // variant 10
  return fmt::format("{:08x}-{:04x}-{:04x}-{:04x}-{:012x}", hi >> 32, (hi >> 16) & 0xffff, hi & 0xffff, lo >> 48,
                     lo & 0xffffffffffffULL);
}

std::string UtcNowIso8601() {
  const auto now = std::chrono::system_clock::now();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", fmt::gmtime(std::chrono::system_clock::to_time_t(now)), ms);
}

std::string ParseUtcTime(const std::string& text, const std::string& what) {
  static const std::regex form(R"((\d{4}-\d{2}-\d{2})(?:T(\d{2}:\d{2})(:\d{2})?(?:\.(\d{1,3})\d*)?)?Z?)");
  std::smatch m;
  if (!std::regex_match(text, m, form))
    ThrowInputError("{}: expected a UTC time in ISO 8601 (2026-12-04, 2026-12-04T17:03, 2026-12-04T17:03:12.345Z), "
                    "found '{}'",
                    what, text);
  const auto field = [&](size_t at) { return std::stoi(text.substr(at, 2)); };
  const bool in_range = field(5) >= 1 && field(5) <= 12 && field(8) >= 1 && field(8) <= 31 &&
                        (!m[2].matched || (field(11) < 24 && field(14) < 60)) && (!m[3].matched || field(17) < 60);
  if (!in_range) ThrowInputError("{}: '{}' is not a valid date and time", what, text);
  std::string millis = m[4].str();
  millis.resize(3, '0');
  return fmt::format("{}T{}{}.{}Z", m[1].str(), m[2].matched ? m[2].str() : "00:00", m[3].matched ? m[3].str() : ":00",
                     millis);
}

std::string StationIdFromHostName(const std::string& host_name) {
  std::string id;
  for (char c : host_name)
    if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') id.push_back(c);
  return id.empty() ? "station" : id;
}

}  // namespace flatscan
