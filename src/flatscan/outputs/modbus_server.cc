#include "flatscan/outputs/modbus_server.h"

#include <modbus/modbus.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <set>

#include <spdlog/spdlog.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr uint16_t kNone = 0xFFFF;  // a value register with nothing to show

uint16_t Clamped(double value, double max) {
  if (!std::isfinite(value)) return kNone;
  return static_cast<uint16_t>(std::clamp(std::round(value), 0.0, max));
}

// Whether a request (function 6 or 16) wrote register `r`.
bool Writes(const uint8_t* request, int header, ModbusRegister r) {
  const int function = request[header];
  const int address = (request[header + 1] << 8) | request[header + 2];
  if (function == MODBUS_FC_WRITE_SINGLE_REGISTER) return address == r;
  if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
    const int count = (request[header + 3] << 8) | request[header + 4];
    return address <= r && r < address + count;
  }
  return false;
}

}  // namespace

ModbusOutcome OutcomeOf(const InspectionRecord& record) {
  if (!record.measured) return ModbusOutcome::kNotMeasured;
  if (record.judgement.pass()) return record.judgement.marginal ? ModbusOutcome::kMarginalPass : ModbusOutcome::kPass;
  return record.judgement.marginal ? ModbusOutcome::kMarginalFail : ModbusOutcome::kFail;
}

ModbusServer::ModbusServer(const std::string& address, int port, size_t recipe_count,
                           std::function<void(size_t)> switch_recipe)
    : recipe_count_(recipe_count), switch_recipe_(std::move(switch_recipe)) {
  context_ = modbus_new_tcp(address.c_str(), port);
  registers_ = modbus_mapping_new(0, 0, kRegisterCount, 0);
  if (context_ == nullptr || registers_ == nullptr) throw std::runtime_error("Modbus: out of memory");
  listen_socket_ = modbus_tcp_listen(context_, 8);
  if (listen_socket_ < 0) {
    const std::string why = std::strerror(errno);
    modbus_mapping_free(registers_);
    modbus_free(context_);
    ThrowInputError("--modbus '{}:{}': cannot listen there ({}); expected a local IPv4 address and a free port",
                    address, port, why);
  }
  // A client that sends half a request must not hold the other clients: 1 s per request.
  modbus_set_indication_timeout(context_, 1, 0);
  running_ = true;
  UpdateStateLocked();
  ShowLocked();
  thread_ = std::thread([this] { Serve(); });
  spdlog::info("Modbus TCP server on {}:{}", address, port);
}

ModbusServer::~ModbusServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  ::close(listen_socket_);
  modbus_mapping_free(registers_);
  modbus_free(context_);
}

void ModbusServer::Publish(const StationRecord& record, const StationCounts& /*counts*/) {
  Result r;
  r.sequence = record.sequence;
  r.outcome = OutcomeOf(record.inspection);
  if (record.inspection.measured) {
    r.flatness_um = Clamped(1000 * record.inspection.values.flatness_mm, 65534);
    r.coverage_per_mille = Clamped(1000 * record.inspection.coverage, 1000);
  }
  std::lock_guard lock(mutex_);
  if (triggers_waiting_ > 0) --triggers_waiting_;
  UpdateStateLocked();
  pending_.push_back(r);
  if (pending_.size() > kMaxPending) {
    spdlog::warn("Modbus: result #{} dropped: the PLC has not acknowledged the last {} results",
                 pending_.front().sequence, kMaxPending);
    pending_.pop_front();
    ++dropped_;
  }
  ShowLocked();
}

void ModbusServer::Stopped(const StationCounts& /*counts*/) {
  std::lock_guard lock(mutex_);
  running_ = false;
  UpdateStateLocked();
}

void ModbusServer::Readiness(bool ready, const std::string& /*reason*/, const StationCounts& /*counts*/) {
  std::lock_guard lock(mutex_);
  source_failing_ = !ready;
  UpdateStateLocked();
}

void ModbusServer::Failed(const StationCounts& /*counts*/, const std::string& /*reason*/) {
  std::lock_guard lock(mutex_);
  running_ = false;
  failed_ = true;
  UpdateStateLocked();
}

void ModbusServer::SetTrigger(std::function<void()> trigger) {
  std::lock_guard lock(mutex_);
  trigger_ = std::move(trigger);
}

void ModbusServer::SetStudyTagsHandler(std::function<void(const StudyTags&)> set_tags) {
  std::lock_guard lock(mutex_);
  set_study_tags_ = std::move(set_tags);
}

uint16_t ModbusServer::Register(ModbusRegister r) const {
  std::lock_guard lock(mutex_);
  return registers_->tab_registers[r];
}

void ModbusServer::SetLocked(ModbusRegister r, uint16_t value) { registers_->tab_registers[r] = value; }

void ModbusServer::UpdateStateLocked() {
  ModbusStationState state = ModbusStationState::kReady;
  if (failed_) state = ModbusStationState::kError;
  else if (!running_) state = ModbusStationState::kNotReady;
  else if (source_failing_) state = ModbusStationState::kSourceFailing;
  else if (triggers_waiting_ > 0) state = ModbusStationState::kBusy;
  SetLocked(kStationState, static_cast<uint16_t>(state));
}

// The oldest result not acknowledged, or none.
void ModbusServer::ShowLocked() {
  const Result none;
  const Result& r = pending_.empty() ? none : pending_.front();
  SetLocked(kSequenceHigh, static_cast<uint16_t>((r.sequence >> 16) & 0xFFFF));
  SetLocked(kSequenceLow, static_cast<uint16_t>(r.sequence & 0xFFFF));
  SetLocked(kOutcome, static_cast<uint16_t>(r.outcome));
  SetLocked(kFlatnessUm, r.flatness_um);
  SetLocked(kCoveragePerMille, r.coverage_per_mille);
  SetLocked(kPending, static_cast<uint16_t>(std::min<size_t>(pending_.size(), 65535)));
  SetLocked(kDropped, static_cast<uint16_t>(std::min<uint32_t>(dropped_, 65535)));
}

// One thread serves every client: select() on the listening socket and the clients.
void ModbusServer::Serve() {
  std::set<int> clients;
  uint8_t request[MODBUS_TCP_MAX_ADU_LENGTH];
  const int header = modbus_get_header_length(context_);
  auto beat = std::chrono::steady_clock::now();
  while (!stop_) {
    if (std::chrono::steady_clock::now() - beat >= std::chrono::seconds(1)) {
      beat += std::chrono::seconds(1);
      std::lock_guard lock(mutex_);
      registers_->tab_registers[kHeartbeat] = ++heartbeat_;
    }
    fd_set readable;
    FD_ZERO(&readable);
    FD_SET(listen_socket_, &readable);
    int top = listen_socket_;
    for (int c : clients) {
      FD_SET(c, &readable);
      top = std::max(top, c);
    }
    timeval wait{0, 100'000};  // stop and heartbeat are checked every 0.1 s
    if (::select(top + 1, &readable, nullptr, nullptr, &wait) <= 0) continue;
    if (FD_ISSET(listen_socket_, &readable)) {
      const int c = ::accept(listen_socket_, nullptr, nullptr);
      if (c >= 0 && c < FD_SETSIZE) clients.insert(c);
      else if (c >= 0) ::close(c);  // beyond select()'s reach
    }
    for (auto it = clients.begin(); it != clients.end();) {
      if (!FD_ISSET(*it, &readable)) {
        ++it;
        continue;
      }
      modbus_set_socket(context_, *it);
      const int length = modbus_receive(context_, request);
      if (length < 0) {  // closed, or a broken request: the client goes
        ::close(*it);
        it = clients.erase(it);
        continue;
      }
      if (length > 0) {
        std::lock_guard lock(mutex_);
        modbus_reply(context_, request, length, registers_);
        AfterWriteLocked(request, header);
      }
      ++it;
    }
  }
  for (int c : clients) ::close(c);
}

// What a PLC's write asks for: the station's own registers are rewritten whatever it
// wrote there (they are read-only in the map).
void ModbusServer::AfterWriteLocked(const uint8_t* request, int header) {
  uint16_t* r = registers_->tab_registers;
  if (Writes(request, header, kAcknowledge) && !pending_.empty() &&
      r[kAcknowledge] == static_cast<uint16_t>(pending_.front().sequence & 0xFFFF))
    pending_.pop_front();
  if (Writes(request, header, kRecipeRequest) && r[kRecipeRequest] != 0) {
    const size_t index = r[kRecipeRequest] - 1u;
    if (index < recipe_count_) {
      switch_recipe_(index);
      active_recipe_ = static_cast<uint16_t>(index);
    } else {
      spdlog::warn("Modbus: recipe index {} requested; there are {} recipes", index, recipe_count_);
    }
    r[kRecipeRequest] = 0;
  }
  if (Writes(request, header, kTrigger) && r[kTrigger] != 0) {
    if (trigger_ && running_) {
      trigger_();
      ++triggers_waiting_;
    } else {
      spdlog::warn("Modbus: trigger refused: {}", trigger_ ? "the station is not ready"
                                                           : "the station's source is not triggered (--trigger software)");
    }
    r[kTrigger] = 0;
  }
  if (set_study_tags_ && (Writes(request, header, kStudyPart) || Writes(request, header, kStudyAppraiser) ||
                          Writes(request, header, kStudyTrial))) {
    const auto tag = [&](ModbusRegister t) { return r[t] == 0 ? std::string() : std::to_string(r[t]); };
    set_study_tags_({tag(kStudyPart), tag(kStudyAppraiser), tag(kStudyTrial)});
  }
  r[kActiveRecipe] = active_recipe_;
  r[kHeartbeat] = heartbeat_;
  UpdateStateLocked();
  ShowLocked();
}

}  // namespace flatscan
