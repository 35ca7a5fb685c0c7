#pragma once
// The MQTT line output (docs/line-outputs.md): each committed record as JSON (the
// store's keys, station_record.h) on flatscan/<station>/result with QoS 1, and the
// station's state retained on flatscan/<station>/state.
//
// Delivery is at least once: a record stays in the publisher's outbox until the broker
// acknowledges it (PUBACK), and everything still in the outbox is sent again, in
// sequence order, each time the connection is made again. A subscriber therefore sees
// every record, first occurrences in sequence order, and may see one again after an
// outage: it de-duplicates on station_id + sequence. The results store is the outbox
// across restarts: the last sequence number acknowledged by the broker is kept in a
// small cursor file beside the store, and a station that starts again sends the
// records after it first (a cursor a crash left behind only repeats records).
//
// State payloads (plain text, retained): "ready" while the station runs ("not_ready"
// while its source fails pair after pair: InspectionStation's not_ready_after), "stopped"
// after a clean stop, "error" when it stopped because it could not record, and
// "offline" (the last will, sent by the broker) when the connection was lost.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "flatscan/station/inspection_station.h"
#include "flatscan/store/results_store.h"

struct mosquitto;

namespace flatscan {

struct MqttOptions {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string station_id;              // topics are flatscan/<station_id>/...
  std::string username, password;      // empty: anonymous; the password is never logged
  std::string tls_ca_file;             // a CA certificate (PEM): TLS to the broker; empty: plain TCP
  std::filesystem::path cursor_file;   // last acknowledged sequence; empty: none (no catch-up)
  int keepalive_s = 10;                // the broker declares the station offline after 1.5 times this
  // The results store's file: with it, at most outbox_in_memory records are held in memory
  // during an outage (about 2 kB each) and the rest is read back from the store (its own
  // read-only connection) as the broker acknowledges; empty: all are held in memory.
  std::string store_path;
  size_t outbox_in_memory = 10000;
};

// "HOST:PORT" (PORT 1-65535; HOST a name, an IPv4 address or [IPv6]) as host and port;
// throws InputError naming `option` and what was expected.
std::pair<std::string, int> ParseHostPort(const std::string& spec, const std::string& option);

class MqttPublisher : public RecordPublisher {
 public:
  // Connects in the background, on its own thread (and again after every failure or
  // outage, after 1, 2, 4, then every 5 s); does not wait for the broker. With a cursor file, the records of `store` after the cursor's
  // sequence are put in the outbox first; without one the cursor starts at the store's
  // last sequence (history is not replayed into a broker that never had it); a cursor
  // file that cannot be read sends everything again. Throws InputError for options
  // libmosquitto refuses (a TLS file that cannot be read).
  MqttPublisher(MqttOptions options, ResultsStore& store);
  ~MqttPublisher() override;
  MqttPublisher(const MqttPublisher&) = delete;
  MqttPublisher& operator=(const MqttPublisher&) = delete;

  void Publish(const StationRecord& record, const StationCounts& counts) override;
  void Stopped(const StationCounts& counts) override;
  void Failed(const StationCounts& counts, const std::string& reason) override;
  void Readiness(bool ready, const std::string& reason, const StationCounts& counts) override;

  // Waits until the broker has acknowledged every record given so far, at most
  // `timeout`; whether it did.
  bool Drain(std::chrono::milliseconds timeout);
  // Records not yet acknowledged by the broker; of them, those held in memory.
  size_t Outstanding() const;
  size_t InMemory() const;

 private:
  static void OnConnect(mosquitto* client, void* self, int rc);
  static void OnDisconnect(mosquitto* client, void* self, int rc);
  static void OnPublish(mosquitto* client, void* self, int mid);
  static void OnLog(mosquitto* client, void* self, int level, const char* text);
  void SendLocked(int64_t sequence);
  void RefillFromStore();
  size_t OutstandingLocked() const;
  void PublishState(const char* state);
  void AdvanceCursorLocked();
  void SaveCursor() const;
  void EndSession(const char* state);
  mosquitto* NewClient();
  void Loop();
  void WaitBeforeRetry(std::chrono::seconds& backoff);

  MqttOptions options_;
  std::string result_topic_, state_topic_;
  mosquitto* client_ = nullptr;
  mutable std::mutex mutex_;
  std::condition_variable drained_;
  std::atomic<bool> connected_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> disconnect_cleanly_{false};
  std::condition_variable wake_;           // a stop cuts a retry's wait short
  std::thread thread_;
  std::string state_ = "ready";
  int state_mid_ = -1;                     // message id of the last state sent at a stop, until acknowledged
  struct OutboxEntry {
    std::string payload;
    bool handed = false;  // to this connection's client, which keeps it until the broker's PUBACK
  };
  std::map<int64_t, OutboxEntry> outbox_;  // by sequence, not yet acknowledged
  std::map<int, int64_t> in_flight_;       // message id -> sequence
  int64_t last_given_ = 0;                 // the newest sequence put in the outbox
  int64_t spilled_from_ = 0;               // > 0: records from this one to last_given_ are in the store only
  std::unique_ptr<ResultsStore> reader_;   // read-only, for records read back (the loop's thread)
  std::string refill_error_;               // the last error reading back, logged once
  int64_t cursor_ = 0;                     // every sequence <= cursor_ is acknowledged
  std::mutex log_mutex_;
  std::string last_log_;                   // libmosquitto's last error, logged once
};

}  // namespace flatscan
