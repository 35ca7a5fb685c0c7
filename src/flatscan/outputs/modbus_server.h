#pragma once
// The PLC output: a Modbus TCP server in the station (libmodbus). The PLC reads holding
// registers (function 3) and writes six of them (functions 6 and 16); the table with
// units and encodings is in docs/plc.md (the controls engineer's page).
//
// Handshake: every committed record joins a queue of results the PLC has not
// acknowledged; the registers show the oldest of them. The PLC reads it, acts on it and
// writes the low 16 bits of its sequence number to kAcknowledge; the registers then show
// the next one (kPending counts them, the shown one included). A PLC that never
// acknowledges holds the queue at kMaxPending results (the oldest are then dropped,
// counted in kDropped, and logged; the records stay in the store); one that disconnects
// finds, when it comes back, the oldest result it has not acknowledged. A verdict is
// therefore never overwritten before the PLC has read it, unless it fell behind by
// kMaxPending parts.
//
// With a triggered source (--trigger software) the PLC starts each part: it writes 1 to
// kTrigger, the station shows busy and takes the next pair (with cameras: the capture),
// and the result is then shown as above: trigger -> busy -> sequence changes -> the PLC
// acknowledges.
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "flatscan/station/inspection_station.h"

struct _modbus;
struct _modbus_mapping_t;

namespace flatscan {

// Holding register addresses (0-based, function 3). The PLC writes 3, 10, 12 and 13-15.
enum ModbusRegister : int {
  kHeartbeat = 0,        // +1 every second while the server runs (wraps at 65535)
  kStationState = 1,     // ModbusStationState
  kActiveRecipe = 2,     // index of the active recipe (0: the first --recipe)
  kRecipeRequest = 3,    // written by the PLC: index + 1 to switch recipes; the station clears it (0)
  kSequenceHigh = 4,     // sequence number of the shown result, high word (0 with kSequenceLow: none)
  kSequenceLow = 5,      // ... low word
  kOutcome = 6,          // ModbusOutcome of the shown result
  kFlatnessUm = 7,       // its flatness, micrometres (rounded; 65535: not measured or none)
  kCoveragePerMille = 8, // its coverage, 0-1000 (65535: not measured or none)
  kPending = 9,          // results not yet acknowledged, the shown one included
  kAcknowledge = 10,     // written by the PLC: the low word of the shown sequence
  kDropped = 11,         // results dropped unacknowledged (queue full), saturating at 65535
  kTrigger = 12,         // written by the PLC: 1 takes the next pair (--trigger software); the station clears it (0)
  kStudyPart = 13,       // written by the PLC: gauge-study tags of the pairs taken from now on (0: none),
  kStudyAppraiser = 14,  //   kept until it writes them again (docs/plc.md, "Gauge studies")
  kStudyTrial = 15,
  kRegisterCount = 16,
};

// kSourceFailing: running, but its source (the cameras) failed not_ready_after pairs in a
// row; triggers are still taken (a pair that comes through makes it ready again).
enum class ModbusStationState : uint16_t { kNotReady = 0, kReady = 1, kBusy = 2, kError = 3, kSourceFailing = 4 };

// From the record's keys: measured, verdict, marginal.
enum class ModbusOutcome : uint16_t {
  kNone = 0,
  kPass = 1,
  kFail = 2,
  kMarginalPass = 3,
  kMarginalFail = 4,
  kNotMeasured = 5,
};

ModbusOutcome OutcomeOf(const InspectionRecord& record);

class ModbusServer : public RecordPublisher {
 public:
  static constexpr size_t kMaxPending = 1000;

  // Listens on address:port (an IPv4 address; "127.0.0.1" by default in the command)
  // and serves every connected client from one thread. `switch_recipe(index)` is called
  // (from the server's thread) when the PLC asks for recipe index < recipe_count.
  // Throws InputError naming "--modbus" when it cannot listen there.
  ModbusServer(const std::string& address, int port, size_t recipe_count,
               std::function<void(size_t)> switch_recipe);
  ~ModbusServer() override;
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  void Publish(const StationRecord& record, const StationCounts& counts) override;
  void Stopped(const StationCounts& counts) override;
  void Failed(const StationCounts& counts, const std::string& reason) override;
  void Readiness(bool ready, const std::string& reason, const StationCounts& counts) override;

  // A trigger from the PLC (kTrigger) calls `trigger` (from the server's thread) and
  // shows the station busy until the result of each trigger is published. Without one,
  // a trigger is refused (logged; the station's source is not triggered).
  void SetTrigger(std::function<void()> trigger);

  // A write of the study registers (13-15) calls `set_tags` (from the server's thread)
  // with their values as decimal text, "" for 0: the tags of the pairs the station takes
  // from then on (InspectionStation::SetStudyTags).
  void SetStudyTagsHandler(std::function<void(const StudyTags&)> set_tags);

  // The register values now (for tests and the log).
  uint16_t Register(ModbusRegister r) const;

 private:
  struct Result {
    int64_t sequence = 0;
    ModbusOutcome outcome = ModbusOutcome::kNone;
    uint16_t flatness_um = 0xFFFF, coverage_per_mille = 0xFFFF;
  };
  void Serve();
  void AfterWriteLocked(const uint8_t* request, int header);
  void ShowLocked();
  void SetLocked(ModbusRegister r, uint16_t value);
  void UpdateStateLocked();

  size_t recipe_count_;
  std::function<void(size_t)> switch_recipe_;
  std::function<void()> trigger_;
  std::function<void(const StudyTags&)> set_study_tags_;
  size_t triggers_waiting_ = 0;  // triggers whose result is not yet published
  _modbus* context_ = nullptr;
  _modbus_mapping_t* registers_ = nullptr;
  int listen_socket_ = -1;
  mutable std::mutex mutex_;
  std::deque<Result> pending_;
  uint32_t dropped_ = 0;
  // The station's own registers, rewritten after every write of a client.
  uint16_t heartbeat_ = 0, active_recipe_ = 0;
  // The state (register 1) follows from these.
  bool running_ = false, failed_ = false, source_failing_ = false;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace flatscan
