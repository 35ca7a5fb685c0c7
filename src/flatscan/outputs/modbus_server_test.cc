// The Modbus TCP server against a libmodbus client playing the PLC, on a free loopback port.
#include "flatscan/outputs/modbus_server.h"

#include <modbus/modbus.h>

#include <array>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

StationRecord Record(int64_t sequence) {
  StationRecord r;
  r.sequence = sequence;
  r.source_id = "part" + std::to_string(sequence);
  InspectionResult result;
  const double flatness = 0.001 * static_cast<double>(sequence);  // sequence micrometres
  result.values = {flatness, flatness, flatness};
  result.coverage = 0.875;
  InspectionInputs inputs;
  r.inspection = sequence % 7 == 0 ? NotMeasuredRecord("no part in the images", InspectionParams{}, {0.02, 0}, inputs)
                                   : MeasuredRecord(result, InspectionParams{}, {0.02, 0.0025}, inputs);
  return r;
}

// The PLC: a libmodbus client on 127.0.0.1:port.
class Plc {
 public:
  explicit Plc(int port) : context_(modbus_new_tcp("127.0.0.1", port)) {}
  ~Plc() {
    modbus_close(context_);
    modbus_free(context_);
  }
  bool Connect() { return modbus_connect(context_) == 0; }
  void Disconnect() { modbus_close(context_); }
  std::array<uint16_t, kRegisterCount> Read() {
    std::array<uint16_t, kRegisterCount> r{};
    EXPECT_EQ(modbus_read_registers(context_, 0, kRegisterCount, r.data()), kRegisterCount) << modbus_strerror(errno);
    return r;
  }
  bool Write(ModbusRegister r, uint16_t value) { return modbus_write_register(context_, r, value) == 1; }
  bool WriteMany(ModbusRegister first, std::vector<uint16_t> values) {
    const int n = static_cast<int>(values.size());
    return modbus_write_registers(context_, first, n, values.data()) == n;
  }

  struct Seen {
    int64_t sequence;
    uint16_t outcome, flatness_um, coverage;
  };
  // Reads and acknowledges results until `count` have been seen (at most `timeout_s`).
  std::vector<Seen> AcknowledgeUntil(size_t count, double timeout_s, std::vector<Seen> seen = {}) {
    testing::WaitFor(
        [&] {
          const auto r = Read();
          if (r[kPending] == 0) return seen.size() >= count;
          seen.push_back({(int64_t{r[kSequenceHigh]} << 16) | r[kSequenceLow], r[kOutcome], r[kFlatnessUm],
                          r[kCoveragePerMille]});
          Write(kAcknowledge, r[kSequenceLow]);
          return seen.size() >= count;
        },
        timeout_s);
    return seen;
  }

 private:
  modbus_t* context_;
};

TEST(ModbusServer, PlcReadsAndAcknowledgesEveryVerdictInOrder) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  Plc plc(port);
  ASSERT_TRUE(plc.Connect());
  const auto idle = plc.Read();
  EXPECT_EQ(idle[kStationState], static_cast<uint16_t>(ModbusStationState::kReady));
  EXPECT_EQ(idle[kPending], 0);
  EXPECT_EQ(idle[kOutcome], static_cast<uint16_t>(ModbusOutcome::kNone));
  EXPECT_EQ(idle[kFlatnessUm], 65535);
  std::thread station([&] {
    for (int64_t s = 1; s <= 40; ++s) {
      server.Publish(Record(s), StationCounts{});
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  const std::vector<Plc::Seen> seen = plc.AcknowledgeUntil(40, 30);
  station.join();
  ASSERT_EQ(seen.size(), 40u);
  for (size_t i = 0; i < seen.size(); ++i) {
    const int64_t s = static_cast<int64_t>(i) + 1;
    EXPECT_EQ(seen[i].sequence, s);
    const StationRecord r = Record(s);
    EXPECT_EQ(seen[i].outcome, static_cast<uint16_t>(OutcomeOf(r.inspection))) << s;
    EXPECT_EQ(seen[i].flatness_um, r.inspection.measured ? s : 65535) << s;
    EXPECT_EQ(seen[i].coverage, r.inspection.measured ? 875 : 65535) << s;
  }
  // 0.020 mm tolerance with a 0.0025 mm guard band: 18-22 um are marginal, above 20 fail.
  EXPECT_EQ(seen[0].outcome, static_cast<uint16_t>(ModbusOutcome::kPass));
  EXPECT_EQ(seen[18].outcome, static_cast<uint16_t>(ModbusOutcome::kMarginalPass));
  EXPECT_EQ(seen[21].outcome, static_cast<uint16_t>(ModbusOutcome::kMarginalFail));
  EXPECT_EQ(seen[6].outcome, static_cast<uint16_t>(ModbusOutcome::kNotMeasured));
  EXPECT_EQ(seen[29].outcome, static_cast<uint16_t>(ModbusOutcome::kFail));
  const auto after = plc.Read();
  EXPECT_EQ(after[kPending], 0);
  EXPECT_EQ(after[kDropped], 0);
}

TEST(ModbusServer, APlcThatNeverAcknowledgesKeepsTheOldestVerdicts) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  for (int64_t s = 1; s <= static_cast<int64_t>(ModbusServer::kMaxPending) + 5; ++s)
    server.Publish(Record(s), StationCounts{});
  Plc plc(port);
  ASSERT_TRUE(plc.Connect());
  const auto r = plc.Read();
  EXPECT_EQ(r[kPending], ModbusServer::kMaxPending);
  EXPECT_EQ(r[kDropped], 5);
  EXPECT_EQ(r[kSequenceLow], 6);  // the oldest kept
  EXPECT_TRUE(plc.Write(kAcknowledge, 99));  // not the shown one: ignored
  EXPECT_EQ(plc.Read()[kSequenceLow], 6);
}

TEST(ModbusServer, APlcThatDisconnectsMidRunMissesNothing) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  for (int64_t s = 1; s <= 10; ++s) server.Publish(Record(s), StationCounts{});
  std::vector<Plc::Seen> seen;
  {
    Plc plc(port);
    ASSERT_TRUE(plc.Connect());
    seen = plc.AcknowledgeUntil(5, 10);
    plc.Disconnect();
  }
  for (int64_t s = 11; s <= 20; ++s) server.Publish(Record(s), StationCounts{});
  Plc again(port);
  ASSERT_TRUE(again.Connect());
  seen = again.AcknowledgeUntil(20, 10, seen);
  ASSERT_EQ(seen.size(), 20u);
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i].sequence, static_cast<int64_t>(i) + 1);
}

TEST(ModbusServer, RecipeRequestsStatesAndReadOnlyRegisters) {
  const int port = testing::FreeLoopbackPort();
  std::vector<size_t> switched;
  ModbusServer server("127.0.0.1", port, 2, [&](size_t index) { switched.push_back(index); });
  Plc plc(port);
  ASSERT_TRUE(plc.Connect());
  EXPECT_TRUE(plc.Write(kRecipeRequest, 2));  // index 1
  auto r = plc.Read();
  EXPECT_EQ(r[kActiveRecipe], 1);
  EXPECT_EQ(r[kRecipeRequest], 0);
  EXPECT_TRUE(plc.Write(kRecipeRequest, 9));  // no such recipe: refused
  r = plc.Read();
  EXPECT_EQ(r[kActiveRecipe], 1);
  EXPECT_EQ(r[kRecipeRequest], 0);
  EXPECT_EQ(switched, std::vector<size_t>{1});
  EXPECT_TRUE(plc.Write(kStationState, 3));  // the station's registers are not the PLC's to write
  EXPECT_TRUE(plc.Write(kPending, 7));
  r = plc.Read();
  EXPECT_EQ(r[kStationState], static_cast<uint16_t>(ModbusStationState::kReady));
  EXPECT_EQ(r[kPending], 0);
  const uint16_t beat = r[kHeartbeat];
  EXPECT_TRUE(testing::WaitFor([&] { return plc.Read()[kHeartbeat] != beat; }, 3));  // it beats every second
  server.Stopped(StationCounts{});
  EXPECT_EQ(plc.Read()[kStationState], static_cast<uint16_t>(ModbusStationState::kNotReady));
  server.Failed(StationCounts{}, "disk full");
  EXPECT_EQ(plc.Read()[kStationState], static_cast<uint16_t>(ModbusStationState::kError));
}

// The handshake of a triggered station: trigger -> busy -> result (sequence changes) ->
// acknowledge -> ready.
TEST(ModbusServer, ATriggerShowsBusyUntilItsResult) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  Plc plc(port);
  ASSERT_TRUE(plc.Connect());
  ASSERT_TRUE(plc.Write(kTrigger, 1));  // no triggered source: refused, cleared
  EXPECT_EQ(plc.Read()[kTrigger], 0);
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kReady));
  std::atomic<int> triggers{0};
  server.SetTrigger([&] { ++triggers; });
  for (int64_t part = 1; part <= 3; ++part) {
    ASSERT_TRUE(plc.Write(kTrigger, 1));
    auto r = plc.Read();  // answered after the write was handled (one thread serves both)
    EXPECT_EQ(triggers, part);
    EXPECT_EQ(r[kStationState], uint16_t(ModbusStationState::kBusy));
    EXPECT_EQ(r[kTrigger], 0);
    EXPECT_EQ(r[kPending], 0);
    server.Publish(Record(part), StationCounts{});
    r = plc.Read();
    EXPECT_EQ(r[kStationState], uint16_t(ModbusStationState::kReady));
    EXPECT_EQ(r[kSequenceLow], part);
    ASSERT_TRUE(plc.Write(kAcknowledge, r[kSequenceLow]));
  }
  // The cameras fail pair after pair: state 4, and triggers are still taken (a pair that
  // comes through is how the station finds its cameras back).
  server.Readiness(false, "5 pairs in a row not delivered", StationCounts{});
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kSourceFailing));
  ASSERT_TRUE(plc.Write(kTrigger, 1));
  // The server answers a write before it acts on it; the next read is served after that.
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kSourceFailing));
  EXPECT_EQ(triggers, 4);
  server.Readiness(true, "", StationCounts{});
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kBusy));  // its result not yet shown
  server.Publish(Record(4), StationCounts{});
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kReady));
  server.Stopped(StationCounts{});
  ASSERT_TRUE(plc.Write(kTrigger, 1));  // a stopped station is not triggered
  EXPECT_EQ(plc.Read()[kStationState], uint16_t(ModbusStationState::kNotReady));
  EXPECT_EQ(triggers, 4);
}

// The PLC's gauge-study registers: each write of them hands the three values to the
// station as tags (decimal text, "" for 0); they keep what the PLC wrote.
TEST(ModbusServer, StudyRegistersTagThePairsTakenFromThenOn) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  Plc plc(port);
  ASSERT_TRUE(plc.Connect());
  ASSERT_TRUE(plc.Write(kStudyPart, 9));  // no handler yet: kept, nothing called
  std::vector<StudyTags> seen;
  server.SetStudyTagsHandler([&](const StudyTags& tags) { seen.push_back(tags); });
  ASSERT_TRUE(plc.Write(kStudyTrial, 2));
  ASSERT_TRUE(plc.Write(kAcknowledge, 5));  // not a study register: no call
  ASSERT_TRUE(plc.WriteMany(kStudyPart, {12, 3, 1}));
  ASSERT_TRUE(plc.WriteMany(kStudyPart, {0, 0, 0}));
  const auto r = plc.Read();  // served after the writes were handled
  EXPECT_EQ(r[kStudyPart], 0);
  EXPECT_EQ(seen, (std::vector<StudyTags>{{"9", "", "2"}, {"12", "3", "1"}, {"", "", ""}}));
}

TEST(ModbusServer, AnAddressItCannotListenOnIsAnInputError) {
  const int port = testing::FreeLoopbackPort();
  ModbusServer first("127.0.0.1", port, 1, [](size_t) {});
  const std::string error = testing::InputErrorOf([&] { ModbusServer second("127.0.0.1", port, 1, [](size_t) {}); });
  EXPECT_EQ(error, "--modbus '127.0.0.1:" + std::to_string(port) +
                       "': cannot listen there (Address already in use); expected a local IPv4 address and a free port");
}

}  // namespace
}  // namespace flatscan
