#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/spdlog.h>

#include "flatscan/acquisition/camera_pair_source.h"
#include "flatscan/exe/cli.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/number_checks.h"
#include "flatscan/outputs/http_server.h"
#include "flatscan/outputs/modbus_server.h"
#include "flatscan/outputs/mqtt_publisher.h"
#include "flatscan/outputs/plant_forwarder.h"
#include "flatscan/station/image_archive.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/station/pair_source.h"
#include "flatscan/station/rate_trigger.h"
#include "flatscan/station/recipe.h"
#include "flatscan/station/status_file.h"
#include "flatscan/station/triggered_source.h"
#include "flatscan/store/postgres_results_store.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// A rotating log: 3 files of 5 MB beside the live one (about a month of a busy line's
// info lines at 100 bytes per record and 20 000 records a day).
constexpr size_t kLogFileBytes = 5 * 1024 * 1024;
constexpr size_t kLogFiles = 3;
constexpr int kThumbnailWidth = 480;  // pixels: the page shows the last part at 320 and problems at 120 (sharp on a dense screen)

std::string HostStationId() {
  char host[256] = {};
  if (gethostname(host, sizeof(host) - 1) != 0) return "station";
  return StationIdFromHostName(host);
}

void CheckStationId(const std::string& id) {
  if (id.empty() || id.size() > 64 ||
      id.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    ThrowInputError("--station-id '{}': expected 1-64 characters from [A-Za-z0-9_-]", id);
}

// A server's ADDR:PORT, or PORT alone: on 127.0.0.1 (loopback unless an address is given).
std::pair<std::string, int> ServerAddress(const std::string& spec, const char* option) {
  return ParseHostPort(spec.find(':') == std::string::npos ? "127.0.0.1:" + spec : spec, option);
}

// `store` with its extension replaced: results.db -> results.log.
std::string Beside(const std::string& store, const char* extension) {
  return std::filesystem::path(store).replace_extension(extension).string();
}

class StationCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("station",
                              "Run an inspection station: measure every pair a source gives with the active recipe, "
                              "commit a record per pair to the results store, then publish it. Runs until SIGINT or "
                              "SIGTERM (finishes the pairs in flight, exit 0) or, with --until-idle, until idle.");
    sub_->footer("Example: flatscan station --recipe shield.yml --source folder:incoming --store results.db\n"
                 "Replay:  flatscan station --recipe shield.yml --source pairs:pairs.csv --store results.db "
                 "--until-idle 5\nThen:    flatscan results --store results.db --csv\nSee docs/station.md.");
    sub_->add_option("--recipe", recipes_, "recipe file (YAML; repeat for several: the first is active)")->required();
    Fills(sub_->add_option("--source", source_,
                     "where pairs come from: folder:DIR (ID_left.png + ID_right.png appearing in DIR, watched), "
                     "pairs:FILE.csv (replay a pairs file), cameras:LEFT,RIGHT (two GenICam cameras by id or serial, "
                     "docs/cameras.md) or aravis-fake:DIR (Aravis's fake cameras showing a simulated dataset's pairs)")
              ->required(),
          "source");
    sub_->add_option("--half-pair-timeout", half_pair_timeout_s_,
                     "folder: seconds after which one image without its partner gets a not-measured record")
        ->default_val(half_pair_timeout_s_)
        ->check(RealIn(0.1, 3600));
    sub_->add_option("--keep-done", keep_done_, "folder: recorded pairs kept in DIR/done/ (the newest; 0: none)")
        ->default_val(keep_done_)
        ->check(IntegerIn(0, 10'000'000));
    sub_->add_option("--store", store_, "results store (SQLite file; created when missing)")->required();
    sub_->add_option("--archive", archive_,
                     "folder for the images of every fail and not-measured pair and one pass pair in N, within a "
                     "quota (the recipe's archive policy)");
    sub_->add_option("--station-id", station_id_, "the station's name in its records (default: the host name)");
    sub_->add_option("--until-idle", until_idle_s_,
                     "exit 0 once this many seconds passed since the last record with nothing in flight")
        ->check(RealIn(0, 1e6));
    sub_->add_option("--log", log_, "rotating log file (default: the store's name with .log)");
    sub_->add_option("--modbus", modbus_,
                     "Modbus TCP server for the PLC on ADDR:PORT (or PORT: on 127.0.0.1); the register map is in "
                     "docs/plc.md");
    sub_->add_option("--trigger", trigger_,
                     "software: a pair per trigger, fired at --trigger-rate or by the PLC (Modbus register 12, "
                     "--modbus); with a replay or a folder, to commission the PLC's handshake before the cameras. "
                     "line0: cameras only, both wired to one trigger line")
        ->check(CLI::IsMember({"software", "line0"}));
    sub_->add_option("--trigger-rate", trigger_rate_hz_, "software triggers at this rate (per second)")
        ->check(RealIn(0.01, 1000));
    sub_->add_option("--frame-timeout", frame_timeout_ms_,
                     "cameras: milliseconds a trigger waits for its frames (then: not measured)")
        ->default_val(frame_timeout_ms_)
        ->check(IntegerIn(10, 60000));
    sub_->add_option("--max-skew", max_skew_ms_,
                     "cameras: frames of one trigger further apart than this (ms) are not measured: cameras out of "
                     "sync")
        ->default_val(max_skew_ms_)
        ->check(IntegerIn(1, 10000));
    sub_->add_option("--skew-clock", skew_clock_,
                     "cameras: the clock --max-skew is measured on: host (arrival) or camera (exposure; both cameras "
                     "synchronised by PTP)")
        ->default_val(skew_clock_)
        ->check(CLI::IsMember({"host", "camera"}));
    sub_->add_option("--pixel-format", pixel_format_,
                     "cameras: Mono8, or Mono10/Mono12/Mono16 reduced to 8 bits by keeping the 8 most significant "
                     "(docs/cameras.md)")
        ->default_val(pixel_format_);
    sub_->add_option("--not-ready-after", not_ready_after_,
                     "this many pairs in a row the source could not deliver (camera faults) make the station report "
                     "itself not ready (status file, MQTT state, Modbus state 4) until a pair comes through; 0: never")
        ->default_val(not_ready_after_)
        ->check(IntegerIn(0, 1000000));
    sub_->add_option("--mqtt", mqtt_, "MQTT broker HOST:PORT: each record on flatscan/<station>/result (QoS 1), the "
                                      "state retained on flatscan/<station>/state (docs/line-outputs.md)");
    sub_->add_option("--mqtt-user", mqtt_user_, "MQTT user name");
    sub_->add_option("--mqtt-password-file", mqtt_password_file_,
                     "file whose first line is the MQTT password (never on the command line, never logged)");
    sub_->add_option("--mqtt-tls-ca", mqtt_tls_ca_, "CA certificate (PEM) of the broker: TLS to the broker");
    sub_->add_option("--plant-store", plant_store_,
                     "plant-wide PostgreSQL store (postgresql://user@host:port/dbname; a password belongs in "
                     "~/.pgpass): every record is forwarded to it after the local store, catching up after an outage "
                     "(docs/line-outputs.md)");
    sub_->add_option("--http", http_,
                     "serve the station's web page and /api/summary on ADDR:PORT (or PORT: on 127.0.0.1); read-only "
                     "unless --http-token-file (docs/web.md)");
    sub_->add_option("--http-token-file", http_token_file_,
                     "file whose first line is the token a recipe change over HTTP must carry (Authorization: Bearer)");
    sub_->add_option("--http-max-rate", http_max_rate_,
                     "requests per second the web server answers (beyond: 429), so that no client slows measuring")
        ->default_val(http_max_rate_)
        ->check(RealIn(1, 100000));
    sub_->add_option("--shifts", shifts_,
                     "local times at which shifts start (the station computer's time zone), for the page's shift "
                     "counters")
        ->default_val(shifts_);
    sub_->add_option("--status", status_, "status file (JSON, rewritten after every record; default: the store's "
                                          "name with .status.json)");
  }

  int Run() override {
    if (station_id_.empty()) station_id_ = HostStationId();
    CheckStationId(station_id_);
    std::vector<LoadedRecipe> recipes;
    for (const std::string& r : recipes_) recipes.push_back(LoadRecipe(r));
    const ShiftCalendar shifts = ShiftCalendar::Parse(shifts_, "--shifts");
    const nlohmann::json calibration = http_.empty() ? nlohmann::json() : CalibrationHealth(recipes);  // the page's
    std::vector<std::string> recipe_names;
    for (const LoadedRecipe& r : recipes) recipe_names.push_back(r.recipe.name);
    Sources sources = MakeSources(recipes.front().recipe.camera);
    LogToFile(log_.empty() ? Beside(store_, ".log") : log_);
    std::unique_ptr<ResultsStore> store;
    try {
      store = OpenSqliteStore(store_, true);
    } catch (const StoreError& e) {
      ThrowInputError("--store: {}", e.what());
    }
    StationOptions options;
    options.station_id = station_id_;
    options.software_version = FLATSCAN_VERSION;
    options.until_idle_s = until_idle_s_;
    options.not_ready_after = not_ready_after_;
    // The page shows them; the archive keeps them beside the images for the report.
    if (!http_.empty() || !archive_.empty()) options.thumbnail_width = kThumbnailWidth;
    std::unique_ptr<ImageArchive> archive;
    if (!archive_.empty()) archive = MakeArchive(recipes);
    StatusFile status(status_.empty() ? Beside(store_, ".status.json") : status_, station_id_,
                      recipes.front().recipe.name);
    InspectionStation station(std::move(recipes), sources.Station(), *store, options);
    station.AddPublisher(&status);
    const std::unique_ptr<MqttPublisher> mqtt = MakeMqtt(*store);
    if (mqtt) station.AddPublisher(mqtt.get());
    const std::unique_ptr<PlantForwarder> plant = MakePlantForwarder();
    if (plant) station.AddPublisher(plant.get());
    std::unique_ptr<ModbusServer> modbus;
    if (!modbus_.empty()) {
      const auto [address, port] = ServerAddress(modbus_, "--modbus");
      modbus = std::make_unique<ModbusServer>(address, port, recipes_.size(),
                                              [&station](size_t index) { station.SetActiveRecipe(index); });
      if (sources.trigger) modbus->SetTrigger(sources.trigger);
      modbus->SetStudyTagsHandler([&station](const StudyTags& tags) { station.SetStudyTags(tags); });
      station.AddPublisher(modbus.get());
    }
    const std::unique_ptr<StationHttpServer> http = MakeHttp(*store, station, recipe_names, sources.cameras, shifts, calibration);
    if (http) station.AddPublisher(http.get());
    station.SetArchive(archive.get());
    std::optional<RateTrigger> rate;
    if (trigger_rate_hz_) rate.emplace(*trigger_rate_hz_, sources.trigger);
    try {
      station.Run(StopGracefullyOnSignal());
      rate.reset();
      if (sources.cameras)
        spdlog::info("{}: {} triggers fired, {} reconnection(s)", sources.cameras->Name(), sources.cameras->Triggers(),
                     sources.cameras->Reconnections());
    } catch (const StoreError& e) {
      spdlog::error("the station stops: it cannot record ({})", e.what());
      return 2;
    }
    return 0;
  }

 private:
  // The station's source and how a software trigger reaches it.
  struct Sources {
    std::unique_ptr<PairSource> source;
    std::unique_ptr<TriggeredSource> triggered;  // a file source released by triggers
    std::function<void()> trigger;               // fires one trigger; empty: none
    CameraPairSource* cameras = nullptr;         // a camera source
    PairSource& Station() const { return triggered ? *triggered : *source; }
  };

  Sources MakeSources(const CameraSettings& camera_settings) const {
    if (trigger_rate_hz_ && trigger_ == "line0")
      ThrowInputError("--trigger-rate fires software triggers: it does not go with --trigger line0");
    const bool camera = source_.rfind("cameras:", 0) == 0 || source_.rfind("aravis-fake:", 0) == 0;
    Sources s;
    if (camera) {
      std::unique_ptr<CameraPairSource> cameras = MakeCameraSource(trigger_ == "line0", camera_settings);
      if (trigger_ != "line0") s.trigger = [c = cameras.get()] { c->Trigger(); };
      s.cameras = cameras.get();
      s.source = std::move(cameras);
      return s;
    }
    if (trigger_ == "line0") ThrowInputError("--trigger line0: the trigger line is a camera's: --source cameras:L,R");
    FolderSourceOptions folder;
    folder.half_pair_timeout = std::chrono::milliseconds(std::llround(1000 * half_pair_timeout_s_));
    folder.keep_done = keep_done_;
    s.source = MakePairSource(source_, folder);
    if (!trigger_.empty() && modbus_.empty() && !trigger_rate_hz_)
      ThrowInputError("--trigger software needs --modbus (the PLC triggers there) or --trigger-rate HZ");
    if (!trigger_.empty() || trigger_rate_hz_) {
      s.triggered = std::make_unique<TriggeredSource>(*s.source);
      s.trigger = [t = s.triggered.get()] { t->Trigger(); };
    }
    return s;
  }

  // cameras:L,R or aravis-fake:DIR. Software triggers come from the rate or the PLC; the
  // fake cameras without either are triggered whenever the station is ready for a pair.
  // The cameras start with the first recipe's exposure and gain (refused: exit 2).
  std::unique_ptr<CameraPairSource> MakeCameraSource(bool line0, const CameraSettings& camera) const {
    CameraSourceOptions o;
    o.acquisition.exposure_us = camera.exposure_us;
    o.acquisition.gain_db = camera.gain_db;
    o.acquisition.trigger = line0 ? TriggerSource::kLine0 : TriggerSource::kSoftware;
    o.frame_timeout = std::chrono::milliseconds(frame_timeout_ms_);
    o.max_skew = std::chrono::milliseconds(max_skew_ms_);
    o.acquisition.pixel_format = ParsePixelFormat(pixel_format_, "--pixel-format");
    o.skew_clock = skew_clock_ == "camera" ? CameraSourceOptions::Clock::kCamera : CameraSourceOptions::Clock::kHost;
    const bool external = trigger_rate_hz_ || !modbus_.empty();
    if (source_.rfind("aravis-fake:", 0) == 0) {
      const std::string dir = source_.substr(std::string("aravis-fake:").size());
      if (dir.empty()) ThrowInputError("--source '{}': expected aravis-fake:DIR (a simulated dataset)", source_);
      o.trigger_on_demand = !line0 && !external;
      return MakeFakeSource(source_, MakeDatasetScene(dir), o);
    }
    if (!line0 && !external)
      ThrowInputError("--source {}: software triggers need --trigger-rate HZ or --modbus (the PLC triggers), or "
                      "--trigger line0",
                      source_);
    return flatscan::MakeCameraSource(source_, o);
  }

  // One archive folder for every recipe: the largest quota and retention any of them asks for.
  std::unique_ptr<ImageArchive> MakeArchive(const std::vector<LoadedRecipe>& recipes) const {
    double quota_mb = 0, retention_days = 0;
    for (const LoadedRecipe& r : recipes) {
      quota_mb = std::max(quota_mb, r.recipe.archive.quota_mb);
      retention_days = std::max(retention_days, r.recipe.archive.fail_retention_days);
    }
    return std::make_unique<ImageArchive>(archive_, quota_mb, retention_days);
  }

  // The web page: its figures start from the whole store; parts are read through a second,
  // read-only connection (SQLite lets it read while the station writes).
  std::unique_ptr<StationHttpServer> MakeHttp(ResultsStore& store, InspectionStation& station,
                                              const std::vector<std::string>& recipe_names,
                                              const CameraPairSource* cameras, const ShiftCalendar& shifts,
                                              const nlohmann::json& calibration) const {
    if (http_.empty()) {
      if (!http_token_file_.empty()) ThrowInputError("--http-token-file needs --http ADDR:PORT");
      return nullptr;
    }
    HttpServerOptions o;
    std::tie(o.address, o.port) = ServerAddress(http_, "--http");
    o.max_requests_per_s = http_max_rate_;
    if (!http_token_file_.empty()) o.token = FirstLine(http_token_file_, "--http-token-file", "token");
    LiveSummary summary(station_id_, shifts, std::chrono::system_clock::now());
    store.ForEach({}, [&](const StationRecord& r) { summary.AddStored(r); });
    StationHooks hooks;
    ReadRecordsFrom(OpenSqliteStore(store_, false), hooks);
    hooks.recipe_names = [recipe_names] { return recipe_names; };
    hooks.set_active_recipe = [&station](size_t index) { station.SetActiveRecipe(index); };
    hooks.health = [this, &station, recipe_names, cameras, calibration] {
      nlohmann::json h = {{"active_recipe", recipe_names[station.ActiveRecipe()]},
                          {"recipes", recipe_names},
                          {"store", store_},
                          {"software_version", FLATSCAN_VERSION},
                          {"calibration", calibration},
                          {"outputs", Outputs()}};
      if (cameras)
        h["cameras"] = {{"source", cameras->Name()},
                        {"triggers", cameras->Triggers()},
                        {"reconnections", cameras->Reconnections()}};
      return h;
    };
    auto server = std::make_unique<StationHttpServer>(o, std::move(summary), std::move(hooks));
    spdlog::info("web page on http://{}:{}/", o.address, server->Port());
    return server;
  }

  // The outputs this station was started with (no secrets: no URI, no user).
  nlohmann::json Outputs() const {
    nlohmann::json o = nlohmann::json::object();
    if (!mqtt_.empty()) o["mqtt"] = mqtt_;
    if (!modbus_.empty()) o["modbus"] = modbus_;
    if (!plant_store_.empty()) o["plant_store"] = "forwarding";
    if (!archive_.empty()) o["archive"] = archive_;
    return o;
  }

  // Per recipe: its rig and plane files, their SHA-256 and age (days since written).
  static nlohmann::json CalibrationHealth(const std::vector<LoadedRecipe>& recipes) {
    const auto age_days = [](const std::string& file) -> nlohmann::json {
      std::error_code error;
      const auto written = std::filesystem::last_write_time(file, error);
      if (error) return nullptr;
      const auto age = std::filesystem::file_time_type::clock::now() - written;
      return std::round(std::chrono::duration<double, std::ratio<86400>>(age).count() * 10) / 10;
    };
    nlohmann::json list = nlohmann::json::array();
    for (const LoadedRecipe& r : recipes)
      list.push_back({{"recipe", r.recipe.name},
                      {"rig", r.inputs.rig_file},
                      {"rig_sha256", r.inputs.rig_sha256},
                      {"rig_age_days", age_days(r.inputs.rig_file)},
                      {"plane", r.inputs.plane_file},
                      {"plane_sha256", r.inputs.plane_sha256},
                      {"plane_age_days", age_days(r.inputs.plane_file)}});
    return list;
  }

  std::unique_ptr<MqttPublisher> MakeMqtt(ResultsStore& store) const {
    if (mqtt_.empty()) {
      if (!mqtt_user_.empty() || !mqtt_password_file_.empty() || !mqtt_tls_ca_.empty())
        ThrowInputError("--mqtt-user, --mqtt-password-file and --mqtt-tls-ca need --mqtt HOST:PORT");
      return nullptr;
    }
    if (!mqtt_password_file_.empty() && mqtt_user_.empty())
      ThrowInputError("--mqtt-password-file needs --mqtt-user (a password without a user name is not sent)");
    MqttOptions o;
    std::tie(o.host, o.port) = ParseHostPort(mqtt_, "--mqtt");
    o.station_id = station_id_;
    o.username = mqtt_user_;
    if (!mqtt_password_file_.empty()) o.password = FirstLine(mqtt_password_file_, "--mqtt-password-file", "password");
    o.tls_ca_file = mqtt_tls_ca_;
    o.cursor_file = Beside(store_, ".mqtt.json");
    o.store_path = store_;  // at most 10,000 records wait in memory; the rest in the store
    return std::make_unique<MqttPublisher>(std::move(o), store);
  }

  std::unique_ptr<PlantForwarder> MakePlantForwarder() const {
    if (plant_store_.empty()) return nullptr;
    // The value is not repeated in a message: it may hold a password.
    if (!IsPostgresUri(plant_store_))
      ThrowInputError("--plant-store: expected a PostgreSQL URI (postgresql://user@host:port/dbname)");
    try {
      return std::make_unique<PlantForwarder>(PlantForwarderOptions{plant_store_, station_id_, store_});
    } catch (const InputError& e) {
      ThrowInputError("--plant-store: {}", e.what());
    } catch (const StoreError& e) {
      ThrowInputError("--store: {}", e.what());
    }
  }

  // The first line of a secret's file, without its line end.
  static std::string FirstLine(const std::string& file, const char* option, const char* what) {
    std::ifstream in(file);
    std::string line;
    if (!in || !std::getline(in, line) || line.empty())
      ThrowInputError("{} '{}': expected a readable file whose first line is the {}", option, file, what);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  }

  static void LogToFile(const std::string& file) {
    try {
      auto sink = std::make_shared<spdlog::sinks::rotating_file_sink_mt>(file, kLogFileBytes, kLogFiles);
      sink->set_formatter(
          std::make_unique<spdlog::pattern_formatter>("%Y-%m-%dT%H:%M:%S.%eZ %l: %v", spdlog::pattern_time_type::utc));
      // The file has every record's line; stderr keeps the level -q chose.
      const auto logger = spdlog::default_logger();
      for (const auto& console : logger->sinks()) console->set_level(logger->level());
      sink->set_level(spdlog::level::info);
      logger->sinks().push_back(sink);
      logger->set_level(spdlog::level::info);
    } catch (const spdlog::spdlog_ex& e) {
      ThrowInputError("--log '{}': cannot write the log file ({})", file, e.what());
    }
  }

  std::vector<std::string> recipes_;
  std::string source_, store_, station_id_, log_, status_, archive_;
  std::string mqtt_, mqtt_user_, mqtt_password_file_, mqtt_tls_ca_, modbus_, plant_store_, trigger_;
  std::string pixel_format_ = "Mono8", skew_clock_ = "host";
  std::string http_, http_token_file_, shifts_ = "06:00,14:00,22:00";
  double http_max_rate_ = HttpServerOptions{}.max_requests_per_s;
  std::optional<double> until_idle_s_, trigger_rate_hz_;
  int frame_timeout_ms_ = 1000, max_skew_ms_ = 20, not_ready_after_ = StationOptions{}.not_ready_after;
  double half_pair_timeout_s_ = 10;
  int keep_done_ = 1000;
};

}  // namespace

std::unique_ptr<Command> MakeStationCommand() { return std::make_unique<StationCommand>(); }

}  // namespace flatscan
