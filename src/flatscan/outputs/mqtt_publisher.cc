#include "flatscan/outputs/mqtt_publisher.h"

#include <charconv>
#include <fstream>
#include <utility>

#include <mosquitto.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kQos = 1;  // at least once

// The cursor file: {"acked_through": N}. Missing: nullopt.
std::optional<int64_t> ReadCursor(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return std::nullopt;
  try {
    return nlohmann::json::parse(in).at("acked_through").get<int64_t>();
  } catch (const nlohmann::json::exception&) {
    ThrowInputError("{}: expected {{\"acked_through\": N}} (the MQTT output's cursor); delete it to start from the "
                    "store's last record",
                    file.string());
  }
}

// libmosquitto is initialised once per process (its own reference count is not
// thread-safe in 2.0, so it is done here, before any client exists).
void InitLibrary() {
  static const int once = [] {
    mosquitto_lib_init();
    return 0;
  }();
  (void)once;
}

}  // namespace

std::pair<std::string, int> ParseHostPort(const std::string& spec, const std::string& option) {
  const auto colon = spec.rfind(':');
  std::string host = colon == std::string::npos ? "" : spec.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  int port = 0;
  const char* first = colon == std::string::npos ? spec.data() + spec.size() : spec.data() + colon + 1;
  const char* last = spec.data() + spec.size();
  const auto [end, ec] = std::from_chars(first, last, port);
  if (host.empty() || ec != std::errc() || end != last || first == last || port < 1 || port > 65535)
    ThrowInputError("{} '{}': expected HOST:PORT (a host name or address, a port 1-65535)", option, spec);
  return {host, port};
}

MqttPublisher::MqttPublisher(MqttOptions options, ResultsStore& store)
    : options_(std::move(options)),
      result_topic_("flatscan/" + options_.station_id + "/result"),
      state_topic_("flatscan/" + options_.station_id + "/state") {
  InitLibrary();
  // The outbox first: records the broker never acknowledged, from the store.
  const int64_t last = store.LastSequence();
  const std::optional<int64_t> cursor =
      options_.cursor_file.empty() ? std::nullopt : ReadCursor(options_.cursor_file);
  cursor_ = cursor.value_or(last);
  if (cursor_ > last) {
    spdlog::warn("{}: acknowledged through #{} but the store ends at #{} (another store?): starting after #{}",
                 options_.cursor_file.string(), cursor_, last, last);
    cursor_ = last;
  }
  if (cursor_ < last) {
    store.ForEach({}, [&](const StationRecord& r) {
      if (r.sequence > cursor_) outbox_[r.sequence] = StationRecordToJson(r).dump();
    });
    spdlog::info("MQTT: {} record(s) after #{} not yet acknowledged by a broker: sent first", outbox_.size(), cursor_);
  }
  last_given_ = last;
  if (!cursor && !options_.cursor_file.empty()) SaveCursor();  // from now on, what is not acknowledged is caught up

  client_ = mosquitto_new(("flatscan-" + options_.station_id).c_str(), true, this);
  if (client_ == nullptr) throw std::runtime_error("MQTT: cannot create a client (out of memory)");
  mosquitto_connect_callback_set(client_, &MqttPublisher::OnConnect);
  mosquitto_disconnect_callback_set(client_, &MqttPublisher::OnDisconnect);
  mosquitto_publish_callback_set(client_, &MqttPublisher::OnPublish);
  mosquitto_log_callback_set(client_, &MqttPublisher::OnLog);
  mosquitto_reconnect_delay_set(client_, 1, 5, true);
  const std::string offline = "offline";
  mosquitto_will_set(client_, state_topic_.c_str(), static_cast<int>(offline.size()), offline.data(), kQos, true);
  if (!options_.username.empty())
    mosquitto_username_pw_set(client_, options_.username.c_str(),
                              options_.password.empty() ? nullptr : options_.password.c_str());
  if (!options_.tls_ca_file.empty()) {
    const int rc = mosquitto_tls_set(client_, options_.tls_ca_file.c_str(), nullptr, nullptr, nullptr, nullptr);
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(client_);
      ThrowInputError("--mqtt-tls-ca '{}': {} (expected a readable CA certificate, PEM)", options_.tls_ca_file,
                      mosquitto_strerror(rc));
    }
  }
  // Asynchronous: the loop thread connects, and connects again after an outage.
  const int rc = mosquitto_connect_async(client_, options_.host.c_str(), options_.port, options_.keepalive_s);
  if (rc != MOSQ_ERR_SUCCESS)
    spdlog::warn("MQTT {}:{}: {} (trying again in the background)", options_.host, options_.port,
                 mosquitto_strerror(rc));
  mosquitto_loop_start(client_);
}

MqttPublisher::~MqttPublisher() { EndSession(nullptr); }

void MqttPublisher::EndSession(const char* state) {
  if (client_ == nullptr) return;
  if (state != nullptr) {
    PublishState(state);
    // A clean stop gives the broker a moment for what is in flight (the state too: a
    // disconnect right behind it could overtake it); what it does not acknowledge stays
    // after the cursor and is sent when the station starts again.
    std::unique_lock lock(mutex_);
    if (!drained_.wait_for(lock, std::chrono::seconds(5), [&] { return outbox_.empty() && state_mid_ < 0; }))
      spdlog::warn("MQTT: {} record(s) not acknowledged by the broker; sent when the station starts again",
                   outbox_.size());
  }
  mosquitto_disconnect(client_);  // a clean disconnect: the broker keeps the retained state, not the will
  mosquitto_loop_stop(client_, false);
  mosquitto_destroy(client_);
  client_ = nullptr;
}

void MqttPublisher::Publish(const StationRecord& record, const StationCounts& /*counts*/) {
  std::lock_guard lock(mutex_);
  outbox_[record.sequence] = StationRecordToJson(record).dump();
  last_given_ = std::max(last_given_, record.sequence);
  if (connected_) SendLocked(record.sequence);
}

void MqttPublisher::Stopped(const StationCounts& /*counts*/) { EndSession("stopped"); }

void MqttPublisher::Failed(const StationCounts& /*counts*/, const std::string& /*reason*/) { EndSession("error"); }

void MqttPublisher::SendLocked(int64_t sequence) {
  const std::string& payload = outbox_.at(sequence);
  int mid = 0;
  const int rc = mosquitto_publish(client_, &mid, result_topic_.c_str(), static_cast<int>(payload.size()),
                                   payload.data(), kQos, false);
  if (rc == MOSQ_ERR_SUCCESS)
    in_flight_[mid] = sequence;
  else  // not sent: it stays in the outbox for the next connection
    spdlog::warn("MQTT: record #{} not sent now ({}); sent again on the next connection", sequence,
                 mosquitto_strerror(rc));
}

void MqttPublisher::PublishState(const char* state) {
  std::lock_guard lock(mutex_);
  state_ = state;
  int mid = 0;
  if (mosquitto_publish(client_, &mid, state_topic_.c_str(), static_cast<int>(state_.size()), state_.data(), kQos,
                        true) == MOSQ_ERR_SUCCESS)
    state_mid_ = mid;
}

void MqttPublisher::OnConnect(mosquitto* client, void* self_ptr, int rc) {
  auto* self = static_cast<MqttPublisher*>(self_ptr);
  if (rc != 0) {  // refused (credentials, protocol): logged; the loop tries again
    spdlog::error("MQTT {}:{}: connection refused: {}", self->options_.host, self->options_.port,
                  mosquitto_connack_string(rc));
    return;
  }
  std::lock_guard lock(self->mutex_);
  spdlog::info("MQTT {}:{}: connected; {} record(s) to send", self->options_.host, self->options_.port,
               self->outbox_.size());
  self->connected_ = true;
  int mid = 0;
  const int sent = mosquitto_publish(client, &mid, self->state_topic_.c_str(), static_cast<int>(self->state_.size()),
                                     self->state_.data(), kQos, true);
  if (self->state_mid_ >= 0 && sent == MOSQ_ERR_SUCCESS) self->state_mid_ = mid;  // a stop waits for this one
  // Everything not acknowledged, oldest first (what the broker already had, it gets twice).
  self->in_flight_.clear();
  for (const auto& entry : self->outbox_) self->SendLocked(entry.first);
}

// libmosquitto's errors (a TLS certificate refused, a broker unreachable) in the log,
// each once until another one comes: it tries again every few seconds.
void MqttPublisher::OnLog(mosquitto* /*client*/, void* self_ptr, int level, const char* text) {
  if ((level & (MOSQ_LOG_ERR | MOSQ_LOG_WARNING)) == 0) return;
  auto* self = static_cast<MqttPublisher*>(self_ptr);
  std::lock_guard lock(self->log_mutex_);
  if (self->last_log_ == text) return;
  self->last_log_ = text;
  spdlog::warn("MQTT {}:{}: {}", self->options_.host, self->options_.port, text);
}

void MqttPublisher::OnDisconnect(mosquitto* /*client*/, void* self_ptr, int rc) {
  auto* self = static_cast<MqttPublisher*>(self_ptr);
  std::lock_guard lock(self->mutex_);
  self->connected_ = false;
  if (rc != 0)
    spdlog::warn("MQTT {}:{}: connection lost; {} record(s) kept until it returns", self->options_.host,
                 self->options_.port, self->outbox_.size());
}

void MqttPublisher::OnPublish(mosquitto* /*client*/, void* self_ptr, int mid) {
  auto* self = static_cast<MqttPublisher*>(self_ptr);
  std::lock_guard lock(self->mutex_);
  if (mid == self->state_mid_) {
    self->state_mid_ = -1;
    self->drained_.notify_all();
    return;
  }
  const auto it = self->in_flight_.find(mid);
  if (it == self->in_flight_.end()) return;  // a message of an earlier connection
  self->outbox_.erase(it->second);
  self->in_flight_.erase(it);
  self->AdvanceCursorLocked();
  if (self->outbox_.empty()) self->drained_.notify_all();  // Drain(), EndSession()
}

// Every sequence below the oldest record still in the outbox is acknowledged.
void MqttPublisher::AdvanceCursorLocked() {
  const int64_t through = outbox_.empty() ? last_given_ : outbox_.begin()->first - 1;
  if (through <= cursor_) return;
  cursor_ = through;
  SaveCursor();
}

void MqttPublisher::SaveCursor() const {
  if (options_.cursor_file.empty()) return;
  try {
    WriteTextFileAtomically(options_.cursor_file, nlohmann::json{{"acked_through", cursor_}}.dump() + "\n");
  } catch (const std::exception& e) {  // only costs repeats after a restart
    spdlog::warn("MQTT: cursor not saved: {}", e.what());
  }
}

bool MqttPublisher::Drain(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return drained_.wait_for(lock, timeout, [&] { return outbox_.empty(); });
}

size_t MqttPublisher::Outstanding() const {
  std::lock_guard lock(mutex_);
  return outbox_.size();
}

}  // namespace flatscan
