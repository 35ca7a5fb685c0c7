#include "flatscan/outputs/mqtt_publisher.h"

#include <charconv>
#include <fstream>
#include <utility>
#include <vector>

#include <mosquitto.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kQos = 1;  // at least once

// The cursor file: {"acked_through": N}. Missing: nullopt. One that cannot be read or
// parsed (a power cut while it was replaced) gives 0: every record is sent again, which
// subscribers de-duplicate; skipping records the broker never had would lose them.
std::optional<int64_t> ReadCursor(const std::filesystem::path& file) {
  std::error_code error;
  if (!std::filesystem::exists(file, error) && !error) return std::nullopt;
  std::ifstream in(file);
  try {
    if (in) return nlohmann::json::parse(in).at("acked_through").get<int64_t>();
  } catch (const nlohmann::json::exception&) {
  }
  spdlog::warn("{}: expected {{\"acked_through\": N}} (the MQTT output's cursor): every record in the store is sent "
               "again",
               file.string());
  return 0;
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
  last_given_ = last;
  if (cursor_ < last) {
    const int64_t in_memory =
        options_.store_path.empty() ? last - cursor_ : std::min<int64_t>(last - cursor_, options_.outbox_in_memory);
    store.ForEachAfter(cursor_, in_memory,
                       [&](const StationRecord& r) { outbox_[r.sequence] = {StationRecordToJsonText(r), false}; });
    if (cursor_ + in_memory < last) spilled_from_ = cursor_ + in_memory + 1;  // the rest is read back later
    spdlog::info("MQTT: {} record(s) after #{} not yet acknowledged by a broker: sent first", last - cursor_, cursor_);
  }
  if (!cursor && !options_.cursor_file.empty()) SaveCursor();  // from now on, what is not acknowledged is caught up

  client_ = NewClient();
  thread_ = std::thread([this] { Loop(); });
}

// A client with the options. A new one for every connection: libmosquitto 2.0 sends the
// messages it still holds again after a reconnection, after anything handed to it in
// between, which would break the order; with a new client, each connection starts from
// the outbox, oldest first, and nothing is sent twice by the library.
mosquitto* MqttPublisher::NewClient() {
  mosquitto* client = mosquitto_new(("flatscan-" + options_.station_id).c_str(), true, this);
  if (client == nullptr) throw std::runtime_error("MQTT: cannot create a client (out of memory)");
  mosquitto_connect_callback_set(client, &MqttPublisher::OnConnect);
  mosquitto_disconnect_callback_set(client, &MqttPublisher::OnDisconnect);
  mosquitto_publish_callback_set(client, &MqttPublisher::OnPublish);
  mosquitto_log_callback_set(client, &MqttPublisher::OnLog);
  const std::string offline = "offline";
  mosquitto_will_set(client, state_topic_.c_str(), static_cast<int>(offline.size()), offline.data(), kQos, true);
  if (!options_.username.empty())
    mosquitto_username_pw_set(client, options_.username.c_str(),
                              options_.password.empty() ? nullptr : options_.password.c_str());
  if (!options_.tls_ca_file.empty()) {
    const int rc = mosquitto_tls_set(client, options_.tls_ca_file.c_str(), nullptr, nullptr, nullptr, nullptr);
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(client);
      ThrowInputError("--mqtt-tls-ca '{}': {} (expected a readable CA certificate, PEM)", options_.tls_ca_file,
                      mosquitto_strerror(rc));
    }
  }
  mosquitto_threaded_set(client, true);  // Publish() comes from the station's thread
  return client;
}

MqttPublisher::~MqttPublisher() { EndSession(nullptr); }

void MqttPublisher::EndSession(const char* state) {
  if (client_ == nullptr) return;
  bool delivered = false;
  if (state != nullptr) {
    PublishState(state);
    // A clean stop gives the broker a moment for what is in flight (the state too: a
    // disconnect right behind it could overtake it); what it does not acknowledge stays
    // after the cursor and is sent when the station starts again.
    std::unique_lock lock(mutex_);
    delivered = drained_.wait_for(lock, std::chrono::seconds(5),
                                  [&] { return outbox_.empty() && spilled_from_ == 0 && state_mid_ < 0; });
    if (!delivered)
      spdlog::warn("MQTT: {} record(s) not acknowledged by the broker; sent when the station starts again",
                   OutstandingLocked());
  }
  // Delivered: a clean DISCONNECT (the broker keeps the retained state). Otherwise the
  // socket is just closed, and the broker publishes the will, "offline".
  disconnect_cleanly_ = delivered;
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  mosquitto_destroy(client_);
  client_ = nullptr;
}

// The connection's own loop (not mosquitto_loop_start: with libmosquitto 2.0.11 its thread
// gives up for good after a TLS or protocol error, never starts when the first connection
// is refused, and can block a stop for minutes in a blocking connect): a non-blocking
// connect, mosquitto_loop() in 0.1 s steps, and every failure retried after 1, 2, 4, 5,
// 5 ... s, each wait cut short by a stop.
void MqttPublisher::Loop() {
  auto backoff = std::chrono::seconds(1);
  bool open = false;
  while (!stop_) {
    if (!open) {
      const int rc = mosquitto_connect_async(client_, options_.host.c_str(), options_.port, options_.keepalive_s);
      open = rc == MOSQ_ERR_SUCCESS;
      if (!open) {
        OnLog(client_, this, MOSQ_LOG_WARNING, mosquitto_strerror(rc));
        WaitBeforeRetry(backoff);
        continue;
      }
    }
    const int rc = mosquitto_loop(client_, 100, 1);
    if (rc != MOSQ_ERR_SUCCESS) {  // lost or never made: any error is retried, on a new client
      open = false;
      {
        std::lock_guard lock(mutex_);
        connected_ = false;
        in_flight_.clear();
        for (auto& entry : outbox_) entry.second.handed = false;
        mosquitto_destroy(client_);
        client_ = NewClient();
      }
      WaitBeforeRetry(backoff);
    } else if (connected_) {
      backoff = std::chrono::seconds(1);
      RefillFromStore();
    }
  }
  if (open && disconnect_cleanly_) {
    mosquitto_disconnect(client_);
    for (int i = 0; i < 10 && mosquitto_loop(client_, 100, 1) == MOSQ_ERR_SUCCESS; ++i) {
    }
  }
}

void MqttPublisher::WaitBeforeRetry(std::chrono::seconds& backoff) {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, backoff, [&] { return stop_.load(); });
  backoff = std::min(2 * backoff, std::chrono::seconds(5));
}

void MqttPublisher::Publish(const StationRecord& record, const StationCounts& /*counts*/) {
  std::lock_guard lock(mutex_);
  last_given_ = std::max(last_given_, record.sequence);
  const bool bounded = !options_.store_path.empty();
  if (spilled_from_ > 0 || (bounded && outbox_.size() >= options_.outbox_in_memory)) {
    if (spilled_from_ == 0) {
      spilled_from_ = record.sequence;
      spdlog::warn("MQTT: {} records wait for the broker; from #{} on they wait in the store only and are read back "
                   "as it acknowledges",
                   outbox_.size(), record.sequence);
    }
    return;
  }
  outbox_[record.sequence] = {StationRecordToJsonText(record), false};
  if (connected_) SendLocked(record.sequence);  // otherwise at the connection, in order
}

// Records that wait in the store only, read back (in order, after everything in memory)
// once the broker has acknowledged half of what memory holds. On the loop's thread; the
// store is read and the payloads made without the lock, so the station is not held up.
void MqttPublisher::RefillFromStore() {
  int64_t from = 0, through = 0;
  size_t room = 0;
  {
    std::lock_guard lock(mutex_);
    if (spilled_from_ == 0 || outbox_.size() > options_.outbox_in_memory / 2) return;
    from = spilled_from_;
    through = last_given_;  // a record committed but not yet given is not ours yet
    room = options_.outbox_in_memory - outbox_.size();
  }
  std::vector<std::pair<int64_t, std::string>> read;
  try {
    if (!reader_) reader_ = OpenSqliteStore(options_.store_path, false);
    reader_->ForEachAfter(from - 1, int64_t(room), [&](const StationRecord& r) {
      if (r.sequence <= through) read.emplace_back(r.sequence, StationRecordToJsonText(r));
    });
    refill_error_.clear();
  } catch (const StoreError& e) {  // tried again at the next turn of the loop
    if (refill_error_ != e.what()) spdlog::warn("MQTT: cannot read records back from the store: {}", e.what());
    refill_error_ = e.what();
    reader_.reset();
    return;
  }
  std::lock_guard lock(mutex_);
  for (auto& [sequence, payload] : read) {
    outbox_[sequence] = {std::move(payload), false};
    if (connected_) SendLocked(sequence);
  }
  const int64_t last = read.empty() ? from - 1 : read.back().first;
  spilled_from_ = last >= last_given_ ? 0 : last + 1;
}

void MqttPublisher::Stopped(const StationCounts& /*counts*/) { EndSession("stopped"); }

void MqttPublisher::Readiness(bool ready, const std::string& /*reason*/, const StationCounts& /*counts*/) {
  PublishState(ready ? "ready" : "not_ready");
}

void MqttPublisher::Failed(const StationCounts& /*counts*/, const std::string& /*reason*/) { EndSession("error"); }

// Hands a record to the connected client: it sends it (in order, at most 20 awaiting
// their PUBACK) and keeps it until the broker acknowledges it.
void MqttPublisher::SendLocked(int64_t sequence) {
  OutboxEntry& entry = outbox_.at(sequence);
  int mid = 0;
  const int rc = mosquitto_publish(client_, &mid, result_topic_.c_str(), static_cast<int>(entry.payload.size()),
                                   entry.payload.data(), kQos, false);
  if (rc == MOSQ_ERR_SUCCESS || rc == MOSQ_ERR_NO_CONN) {
    entry.handed = true;
    in_flight_[mid] = sequence;
  } else {  // not queued (out of memory): handed again at the next connection
    spdlog::warn("MQTT: record #{} not queued ({}); tried again at the next connection", sequence,
                 mosquitto_strerror(rc));
  }
}

void MqttPublisher::PublishState(const char* state) {
  std::lock_guard lock(mutex_);
  state_ = state;
  int mid = 0;
  const int rc = mosquitto_publish(client_, &mid, state_topic_.c_str(), static_cast<int>(state_.size()),
                                   state_.data(), kQos, true);
  if (rc == MOSQ_ERR_SUCCESS || rc == MOSQ_ERR_NO_CONN) state_mid_ = mid;  // sent again at a connection
}

void MqttPublisher::OnConnect(mosquitto* client, void* self_ptr, int rc) {
  auto* self = static_cast<MqttPublisher*>(self_ptr);
  if (rc != 0) {  // refused (credentials, protocol): logged; the loop tries again
    spdlog::error("MQTT {}:{}: connection refused: {}", self->options_.host, self->options_.port,
                  mosquitto_connack_string(rc));
    return;
  }
  std::lock_guard lock(self->mutex_);
  spdlog::info("MQTT {}:{}: connected; {} record(s) not yet acknowledged", self->options_.host, self->options_.port,
               self->OutstandingLocked());
  self->connected_ = true;
  int mid = 0;
  const int sent = mosquitto_publish(client, &mid, self->state_topic_.c_str(), static_cast<int>(self->state_.size()),
                                     self->state_.data(), kQos, true);
  if (self->state_mid_ >= 0 && sent == MOSQ_ERR_SUCCESS) self->state_mid_ = mid;  // a stop waits for this one
  {
    std::lock_guard log_lock(self->log_mutex_);
    self->last_log_.clear();  // an error that comes back is logged again
  }
  // Everything not acknowledged, oldest first (what the broker already had and whose
  // acknowledgement the outage cut off, it gets twice).
  for (auto& entry : self->outbox_)
    if (!entry.second.handed) self->SendLocked(entry.first);
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
  // Logged when a connection that was made is lost, not at each refused attempt.
  if (self->connected_.exchange(false) && rc != 0)
    spdlog::warn("MQTT {}:{}: connection lost; {} record(s) kept until it returns", self->options_.host,
                 self->options_.port, self->OutstandingLocked());
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
  if (self->outbox_.empty() && self->spilled_from_ == 0) self->drained_.notify_all();  // Drain(), EndSession()
}

// Every sequence below the oldest record still in the outbox is acknowledged.
void MqttPublisher::AdvanceCursorLocked() {
  const int64_t through = !outbox_.empty() ? outbox_.begin()->first - 1
                          : spilled_from_ > 0 ? spilled_from_ - 1
                                              : last_given_;
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
  return drained_.wait_for(lock, timeout, [&] { return outbox_.empty() && spilled_from_ == 0; });
}

size_t MqttPublisher::Outstanding() const {
  std::lock_guard lock(mutex_);
  return OutstandingLocked();
}

size_t MqttPublisher::OutstandingLocked() const {
  return outbox_.size() + size_t(spilled_from_ > 0 ? last_given_ - spilled_from_ + 1 : 0);
}

size_t MqttPublisher::InMemory() const {
  std::lock_guard lock(mutex_);
  return outbox_.size();
}

}  // namespace flatscan
