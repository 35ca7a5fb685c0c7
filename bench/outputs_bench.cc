// Latency of the line outputs: from a committed record handed to the MQTT publisher to
// its arrival at a subscriber, through a real mosquitto broker on a loopback port (QoS 1
// both ways, the publisher's cursor file written at each acknowledgement, as a station
// does). One record at a time: the next is published when the last has arrived.
//   build/outputs_bench --benchmark_min_time=2
#include <chrono>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include "flatscan/outputs/mqtt_publisher.h"
#include "flatscan/outputs/mqtt_test_util.h"
#include "flatscan/store/results_store.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

StationRecord Record(int64_t sequence) {
  StationRecord r;
  r.record_id = NewRecordId();
  r.station_id = "bench";
  r.sequence = sequence;
  r.time_utc = UtcNowIso8601();
  r.source_id = "part" + std::to_string(sequence);
  r.recipe_name = "shield";
  r.recipe_sha256 = r.left_sha256 = r.right_sha256 = std::string(64, 'a');
  InspectionResult result;
  result.values = {0.05, 0.05, 0.05};
  result.coverage = 0.9;
  InspectionInputs inputs;
  inputs.id = r.source_id;
  r.inspection = MeasuredRecord(result, InspectionParams{}, {0.1, 0}, inputs);
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

}  // namespace
}  // namespace flatscan

BENCHMARK_MAIN();
