#pragma once
// Test helpers for the MQTT output: a real mosquitto broker on a loopback port and a
// subscriber that keeps what it receives.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "flatscan/util/test_util.h"

struct mosquitto;

namespace flatscan::testing {

// A mosquitto broker on 127.0.0.1:`port` with persistence in `dir` (saved every second:
// it keeps the subscriber's session and its queued messages across a restart). Killed
// by its destructor whatever the test did.
class Broker {
 public:
  Broker(const std::filesystem::path& dir, int port);
  // The listener takes TLS only, with a self-signed certificate for 127.0.0.1 made
  // here (openssl); its path (the CA a client trusts) is returned, or "" on failure.
  std::filesystem::path UseSelfSignedTls();
  // Starts it and waits (at most 10 s) until it accepts connections.
  bool Start();
  // SIGTERM: mosquitto saves its persistence file and exits.
  bool Stop();
  // SIGUSR1: mosquitto writes its persistence file; waits (at most 10 s) until it has.
  bool Save();
  // SIGKILL: what changed since its last save is lost.
  bool Kill();

 private:
  bool Signal(int signal);
  std::filesystem::path dir_;
  int port_;
  std::unique_ptr<BackgroundProcess> process_;
};

// A subscriber to flatscan/<station>/# at QoS 1 with a persistent session (the broker
// queues for it while it is away), keeping the records' sequence numbers and the states.
class Subscriber {
 public:
  Subscriber(int port, const std::string& station);
  ~Subscriber();
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;
  bool Subscribed() const { return subscribed_; }
  std::vector<int64_t> Sequences();
  std::vector<std::string> States();
  // Waits until `count` result messages have arrived, at most `timeout_s`; whether they did.
  bool WaitForResults(size_t count, double timeout_s);
  // The distinct sequences, in the order of their first arrival.
  std::vector<int64_t> FirstArrivals();

 private:
  std::string station_;
  mosquitto* client_ = nullptr;
  std::atomic<bool> subscribed_{false};
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::vector<int64_t> sequences_;
  std::vector<std::string> states_;
};

}  // namespace flatscan::testing
