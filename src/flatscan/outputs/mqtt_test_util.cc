#include "flatscan/outputs/mqtt_test_util.h"

#include <mosquitto.h>
#include <signal.h>

#include <chrono>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

namespace flatscan::testing {
namespace fs = std::filesystem;

Broker::Broker(const fs::path& dir, int port) : dir_(dir), port_(port) {
  std::ofstream(dir / "mosquitto.conf") << "listener " << port << " 127.0.0.1\n"
                                        << "allow_anonymous true\n"
                                        << "persistence true\n"
                                        << "persistence_location " << dir.string() << "/\n"
                                        << "autosave_interval 1\n"
                                        << "user root\n";  // tests run as root: no switch to user 'mosquitto'
}

fs::path Broker::UseSelfSignedTls() {
  const fs::path cert = dir_ / "broker-cert.pem", key = dir_ / "broker-key.pem";
  if (!MakeSelfSignedCertificate(cert, key, dir_ / "openssl.log")) return {};
  std::ofstream(dir_ / "mosquitto.conf", std::ios::app) << "certfile " << cert.string() << "\n"
                                                         << "keyfile " << key.string() << "\n";
  return cert;
}

bool Broker::Start() {
  process_ = std::make_unique<BackgroundProcess>(
      "mosquitto", std::vector<std::string>{"-c", (dir_ / "mosquitto.conf").string()}, dir_ / "mosquitto.log");
  return process_->started() && WaitFor([&] { return LoopbackPortAccepts(port_); }, 10);
}

bool Broker::Stop() { return Signal(SIGTERM); }
bool Broker::Kill() { return Signal(SIGKILL); }

bool Broker::Save() {
  if (!process_) return false;
  const fs::path db = dir_ / "mosquitto.db";
  std::error_code error;
  const auto before = fs::exists(db) ? fs::last_write_time(db, error) : fs::file_time_type::min();
  process_->Signal(SIGUSR1);
  return WaitFor([&] { return fs::exists(db) && fs::last_write_time(db, error) != before; }, 10);
}

bool Broker::Signal(int signal) {
  if (!process_) return false;
  process_->Signal(signal);
  const int code = process_->Wait(10);
  process_.reset();
  return code == 0 || code == 128 + signal;
}

Subscriber::Subscriber(int port, const std::string& station) : station_(station) {
  mosquitto_lib_init();
  client_ = mosquitto_new(("flatscan-test-subscriber-" + station).c_str(), false, this);
  mosquitto_connect_callback_set(client_, [](mosquitto* c, void* self, int rc) {
    if (rc == 0)
      mosquitto_subscribe(c, nullptr, ("flatscan/" + static_cast<Subscriber*>(self)->station_ + "/#").c_str(), 1);
  });
  mosquitto_subscribe_callback_set(client_, [](mosquitto*, void* self, int, int, const int*) {
    static_cast<Subscriber*>(self)->subscribed_ = true;
  });
  mosquitto_message_callback_set(client_, [](mosquitto*, void* self_ptr, const mosquitto_message* m) {
    auto* self = static_cast<Subscriber*>(self_ptr);
    const std::string payload(static_cast<const char*>(m->payload), m->payloadlen);
    std::lock_guard lock(self->mutex_);
    if (std::string(m->topic).ends_with("/state"))
      self->states_.push_back(payload);
    else {  // -1: a payload that is not a record (an exception must not leave this C callback)
      const nlohmann::json j = nlohmann::json::parse(payload, nullptr, false);
      const auto sequence = j.is_object() ? j.find("sequence") : j.end();
      self->sequences_.push_back(sequence != j.end() && sequence->is_number_integer() ? sequence->get<int64_t>() : -1);
    }
    self->arrived_.notify_all();
  });
  mosquitto_reconnect_delay_set(client_, 1, 2, false);
  mosquitto_connect_async(client_, "127.0.0.1", port, 10);
  mosquitto_loop_start(client_);
}

Subscriber::~Subscriber() {
  mosquitto_disconnect(client_);
  mosquitto_loop_stop(client_, false);
  mosquitto_destroy(client_);
}

std::vector<int64_t> Subscriber::Sequences() {
  std::lock_guard lock(mutex_);
  return sequences_;
}

std::vector<std::string> Subscriber::States() {
  std::lock_guard lock(mutex_);
  return states_;
}

bool Subscriber::WaitForResults(size_t count, double timeout_s) {
  std::unique_lock lock(mutex_);
  return arrived_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return sequences_.size() >= count; });
}

std::vector<int64_t> Subscriber::FirstArrivals() {
  std::vector<int64_t> first;
  std::set<int64_t> seen;
  for (int64_t s : Sequences())
    if (seen.insert(s).second) first.push_back(s);
  return first;
}

}  // namespace flatscan::testing
