// Latency of the line outputs, from a committed record handed to an output to its arrival
// where the line reads it, through the real servers on loopback, one record at a time
// (the next is handed over when the last has arrived):
// - MQTT: at a subscriber, through a real mosquitto broker (QoS 1 both ways, the
//   publisher's cursor file written at each acknowledgement, as a station does);
// - PLC: in the Modbus registers, read by a libmodbus client polling as fast as it can
//   (a real PLC adds its own scan cycle), which then acknowledges it;
// - plant store: committed in the station's SQLite store, then forwarded into a real
//   PostgreSQL cluster (the row committed there).
//   build/outputs_bench --benchmark_min_time=2
#include <modbus/modbus.h>

#include <chrono>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include "flatscan/outputs/modbus_server.h"
#include "flatscan/outputs/mqtt_publisher.h"
#include "flatscan/outputs/mqtt_test_util.h"
#include "flatscan/outputs/plant_forwarder.h"
#include "flatscan/store/postgres_test_util.h"
#include "flatscan/store/results_store.h"
#include "flatscan/store/store_test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

StationRecord Record(int64_t sequence) {
  StationRecord r = testing::TestRecord("part" + std::to_string(sequence), std::string(64, 'a'), 0.05, "bench");
  r.sequence = sequence;
  r.time_utc = UtcNowIso8601();
  return r;
}

void BM_RecordToMqttSubscriber(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  testing::ScratchDir dir("outputs-bench");
  const int port = testing::FreeLoopbackPort();
  testing::Broker broker(dir.path(), port);
  if (!broker.Start()) {
    state.SkipWithError("mosquitto did not start");
    return;
  }
  auto store = OpenSqliteStore((dir.path() / "results.db").string(), true);
  testing::Subscriber subscriber(port, "bench");
  MqttOptions options;
  options.port = port;
  options.station_id = "bench";
  options.cursor_file = dir.path() / "results.mqtt.json";
  MqttPublisher publisher(options, *store);
  if (!testing::WaitFor([&] { return subscriber.Subscribed() && !subscriber.States().empty(); }, 10)) {
    state.SkipWithError("no connection to the broker");
    return;
  }
  int64_t sequence = 0;
  for (auto _ : state) {
    const StationRecord record = Record(++sequence);
    publisher.Publish(record, StationCounts{});
    if (!subscriber.WaitForResults(static_cast<size_t>(sequence), 5)) {
      state.SkipWithError("a record did not arrive within 5 s");
      break;
    }
  }
  state.counters["records"] = static_cast<double>(sequence);
}
BENCHMARK(BM_RecordToMqttSubscriber)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RecordToPlcRegister(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  const int port = testing::FreeLoopbackPort();
  ModbusServer server("127.0.0.1", port, 1, [](size_t) {});
  modbus_t* plc = modbus_new_tcp("127.0.0.1", port);
  if (modbus_connect(plc) != 0) {
    modbus_free(plc);
    state.SkipWithError("cannot connect to the Modbus server");
    return;
  }
  int64_t sequence = 0;
  for (auto _ : state) {
    server.Publish(Record(++sequence), StationCounts{});
    uint16_t low = 0;
    while (low != uint16_t(sequence)) {  // the PLC's poll
      if (modbus_read_registers(plc, kSequenceLow, 1, &low) != 1) {
        state.SkipWithError("a register read failed");
        break;
      }
    }
    modbus_write_register(plc, kAcknowledge, low);
  }
  modbus_close(plc);
  modbus_free(plc);
  state.counters["records"] = static_cast<double>(sequence);
}
BENCHMARK(BM_RecordToPlcRegister)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RecordToPlantTable(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  testing::ScratchDir dir("plant-bench");
  testing::PostgresCluster cluster("bench-pw");
  if (!cluster.Start()) {
    state.SkipWithError("PostgreSQL did not start");
    return;
  }
  const std::string local = (dir.path() / "results.db").string();
  auto store = OpenSqliteStore(local, true);
  PlantForwarder forwarder({cluster.Uri(), "bench", local});
  int64_t sequence = 0;
  for (auto _ : state) {
    StationRecord record = testing::TestRecord("part" + std::to_string(++sequence), std::string(64, 'a'), 0.05, "bench");
    store->Commit(record);
    forwarder.Publish(record, StationCounts{});
    if (!forwarder.Drain(std::chrono::seconds(5))) {
      state.SkipWithError("a record was not forwarded within 5 s");
      break;
    }
  }
  state.counters["records"] = static_cast<double>(sequence);
}
BENCHMARK(BM_RecordToPlantTable)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace flatscan

BENCHMARK_MAIN();
