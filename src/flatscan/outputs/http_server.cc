#include "flatscan/outputs/http_server.h"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <httplib.h>
#include <openssl/crypto.h>

#include <algorithm>
#include <chrono>
#include <ctime>

#include "flatscan/outputs/station_page.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kWorkerThreads = 2;
constexpr int kWorkerNice = 10;  // below measuring (nice 0): the line comes first
constexpr size_t kDefaultListed = 100, kMaxListed = 1000;

std::string JsonText(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void Reply(httplib::Response& res, int status, const std::string& text) {
  res.status = status;
  res.set_content(text + "\n", "text/plain");
}

// A positive decimal integer (a sequence number, a limit), or nothing.
std::optional<int64_t> ParsePositiveInteger(const std::string& text) {
  if (text.empty() || text.size() > 18 || text.find_first_not_of("0123456789") != std::string::npos) return {};
  const int64_t n = std::stoll(text);
  return n > 0 ? std::optional<int64_t>(n) : std::nullopt;
}

// The token compared in constant time (OpenSSL's CRYPTO_memcmp): the time a wrong guess
// takes does not tell how much of it was right.
bool SameToken(const std::string& given, const std::string& expected) {
  return given.size() == expected.size() && CRYPTO_memcmp(given.data(), expected.data(), given.size()) == 0;
}

// The calling thread at a lower priority (Linux: per thread), once.
double CpuSeconds(clockid_t clock) {
  timespec t{};
  if (clock_gettime(clock, &t) != 0) return 0;  // a thread that has ended
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double ThisThreadsCpuSeconds() { return CpuSeconds(CLOCK_THREAD_CPUTIME_ID); }

}  // namespace

void ReadRecordsFrom(std::unique_ptr<ResultsStore> reader, StationHooks& hooks) {
  struct Reader {
    std::mutex mutex;
    std::unique_ptr<ResultsStore> store;
  };
  const auto shared = std::make_shared<Reader>();
  shared->store = std::move(reader);
  hooks.record = [shared](int64_t sequence) {
    std::lock_guard lock(shared->mutex);
    std::optional<StationRecord> found;
    shared->store->ForEachAfter(sequence - 1, 1, [&](const StationRecord& r) {
      if (r.sequence == sequence) found = r;
    });
    return found;
  };
  hooks.records = [shared](const TimeRange& range, size_t limit) {
    std::lock_guard lock(shared->mutex);
    std::vector<StationRecord> list;
    struct Enough {};  // stops the store's scan at `limit` (its reader cleans up as it unwinds)
    try {
      shared->store->ForEach(range, [&](const StationRecord& r) {
        list.push_back(r);
        if (list.size() >= limit) throw Enough{};
      });
    } catch (const Enough&) {
    }
    return list;
  };
}

StationHttpServer::StationHttpServer(const HttpServerOptions& options, LiveSummary summary, StationHooks hooks)
    : server_(std::make_unique<httplib::Server>()),
      options_(options),
      hooks_(std::move(hooks)),
      summary_(std::move(summary)),
      bucket_(options.max_requests_per_s),
      bucket_time_(std::chrono::steady_clock::now()) {
  server_->new_task_queue = [] { return new httplib::ThreadPool(kWorkerThreads); };
  server_->set_tcp_nodelay(true);  // a reply goes out at once, not after the client's delayed ACK (40 ms)
  Route();
  // SO_REUSEADDR only: cpp-httplib also sets SO_REUSEPORT, with which a second station on
  // the same port would share it silently instead of being refused.
  server_->set_socket_options([](socket_t socket) {
    const int yes = 1;
    setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  const std::string& address = options.address;
  port_ = options.port == 0 ? server_->bind_to_any_port(address)
                            : (server_->bind_to_port(address, options.port) ? options.port : -1);
  if (port_ < 0)
    ThrowInputError("--http {}:{}: cannot listen there (in use, or not an address of this machine)", address,
                    options.port);
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  clockid_t listening{};
  if (pthread_getcpuclockid(thread_.native_handle(), &listening) == 0) thread_clocks_.push_back(listening);
  // A stop() before the listening loop runs would be lost (and the destructor's join wait
  // for ever): return once it runs.
  while (!server_->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

StationHttpServer::~StationHttpServer() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

void StationHttpServer::JoinWorker() {
  thread_local bool joined = false;  // a worker thread serves one server for its life
  if (joined) return;
  joined = true;
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), kWorkerNice);
  clockid_t clock{};
  if (pthread_getcpuclockid(pthread_self(), &clock) != 0) return;
  std::lock_guard lock(cpu_mutex_);
  thread_clocks_.push_back(clock);
}

StationHttpServer::CpuUsed StationHttpServer::Cpu() {
  CpuUsed used;
  std::lock_guard lock(cpu_mutex_);
  for (const clockid_t clock : thread_clocks_) used.serving_s += CpuSeconds(clock);
  used.publishing_s = publishing_s_;
  return used;
}

bool StationHttpServer::TakeToken() {
  std::lock_guard lock(bucket_mutex_);
  const auto now = std::chrono::steady_clock::now();
  const double rate = options_.max_requests_per_s;
  bucket_ = std::min(rate, bucket_ + rate * std::chrono::duration<double>(now - bucket_time_).count());
  bucket_time_ = now;
  if (bucket_ < 1) return false;
  bucket_ -= 1;
  return true;
}

void StationHttpServer::Route() {
  using httplib::Request;
  using httplib::Response;
  server_->set_pre_routing_handler([this](const Request&, Response& res) {
    JoinWorker();
    if (TakeToken()) return httplib::Server::HandlerResponse::Unhandled;
    res.set_header("Retry-After", "1");
    Reply(res, 429, fmt::format("too many requests: the station answers at most {:g} per second",
                                options_.max_requests_per_s));
    return httplib::Server::HandlerResponse::Handled;
  });
  server_->Get("/", [](const Request&, Response& res) {
    res.set_content(std::string(StationPageHtml()), "text/html; charset=utf-8");
  });
  server_->Get("/api/summary", [this](const Request&, Response& res) {
    res.set_content(SummaryText(), "application/json");
  });
  for (const auto& [path, which] : {std::pair{"/api/trend.svg", LiveSummary::TrendChart::kIndividuals},
                                     std::pair{"/api/moving-range.svg", LiveSummary::TrendChart::kMovingRange}}) {
    server_->Get(path, [this, which = which](const Request&, Response& res) {
      std::string svg;
      {
        std::lock_guard lock(mutex_);
        svg = summary_.TrendSvg(which);
      }
      res.set_header("Cache-Control", "no-store");
      res.set_content(svg, "image/svg+xml");
    });
  }
  server_->Get(R"(/api/parts/(\d{1,18})/image.jpg)", [this](const Request& req, Response& res) {
    const int64_t sequence = std::stoll(req.matches[1]);
    std::string jpeg;
    {
      std::lock_guard lock(mutex_);
      const auto found = images_.find(sequence);
      if (found != images_.end()) jpeg = found->second;
    }
    if (jpeg.empty())
      return Reply(res, 404, fmt::format("no image of part {}: the page keeps the last part's and those of the "
                                         "last {} fails and not-measured parts",
                                         sequence, kProblemImages));
    res.set_header("Cache-Control", "max-age=3600");  // a part's image never changes
    res.set_content(jpeg, "image/jpeg");
  });
  server_->Get(R"(/api/parts/([^/]*))", [this](const Request& req, Response& res) {
    const std::string text = req.matches[1];
    const std::optional<int64_t> sequence = ParsePositiveInteger(text);
    if (!sequence)
      return Reply(res, 400, fmt::format("bad request: a part is named by its sequence number (/api/parts/17), "
                                         "found '{}'",
                                         text));
    std::optional<StationRecord> record;
    try {
      if (hooks_.record) record = hooks_.record(*sequence);
    } catch (const StoreError& e) {
      return Reply(res, 503, std::string("the store cannot be read: ") + e.what());
    }
    if (!record) return Reply(res, 404, fmt::format("not found: the store has no part with sequence {}", *sequence));
    res.set_content(JsonText(StationRecordToJson(*record)), "application/json");
  });
  server_->Get("/api/parts", [this](const Request& req, Response& res) {
    TimeRange range;
    size_t limit = kDefaultListed;
    try {
      for (const auto& [key, value] : req.params) {
        if (key == "from") range.from = ParseUtcTime(value, "from");
        else if (key == "to") range.to = ParseUtcTime(value, "to");
        else if (key == "limit") {
          const std::optional<int64_t> n = ParsePositiveInteger(value);
          if (!n || *n > int64_t(kMaxListed))
            ThrowInputError("limit: expected a whole number from 1 to {}, found '{}'", kMaxListed, value);
          limit = size_t(*n);
        } else {
          ThrowInputError("unknown parameter '{}' (expected from, to, limit)", key);
        }
      }
    } catch (const InputError& e) {
      return Reply(res, 400, std::string("bad request: ") + e.what());
    }
    nlohmann::json list = nlohmann::json::array();
    try {
      if (hooks_.records)
        for (const StationRecord& r : hooks_.records(range, limit)) list.push_back(StationRecordToJson(r));
    } catch (const StoreError& e) {
      return Reply(res, 503, std::string("the store cannot be read: ") + e.what());
    }
    res.set_content(JsonText(list), "application/json");
  });
  server_->Post("/api/recipe", [this](const Request& req, Response& res) {
    if (options_.token.empty() || !hooks_.set_active_recipe || !hooks_.recipe_names)
      return Reply(res, 403, "forbidden: this station is read-only (started without --http-token-file)");
    const std::string bearer = req.get_header_value("Authorization");
    if (bearer.rfind("Bearer ", 0) != 0 || !SameToken(bearer.substr(7), options_.token))
      return Reply(res, 403, "forbidden: changing the recipe needs the station's token (Authorization: Bearer TOKEN)");
    const nlohmann::json body = nlohmann::json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("recipe") || !body["recipe"].is_string())
      return Reply(res, 400, R"(bad request: expected a JSON body {"recipe": NAME})");
    const std::string name = body["recipe"];
    const std::vector<std::string> names = hooks_.recipe_names();
    const auto found = std::find(names.begin(), names.end(), name);
    if (found == names.end())
      return Reply(res, 404, fmt::format("not found: no recipe '{}' on this station (it has: {})", name,
                                         fmt::join(names, ", ")));
    hooks_.set_active_recipe(size_t(found - names.begin()));
    res.set_content(JsonText({{"active_recipe", name}}), "application/json");
  });
  server_->set_error_handler([](const Request& req, Response& res) {
    if (res.status == 404 && res.body.empty())
      Reply(res, 404, "not found: " + req.path + " (the station serves /, /api/summary, /api/trend.svg, "
                      "/api/moving-range.svg, /api/parts and POST /api/recipe)");
  });
}

nlohmann::json StationHttpServer::Summary() {
  nlohmann::json health = hooks_.health ? hooks_.health() : nlohmann::json::object();
  std::lock_guard lock(mutex_);
  nlohmann::json s = summary_.ToJson(std::chrono::system_clock::now());
  s["health"] = std::move(health);
  return s;
}

std::string StationHttpServer::SummaryText() {
  const auto now = std::chrono::steady_clock::now();
  const uint64_t version = version_.load();
  {
    std::lock_guard lock(cache_mutex_);
    if (!summary_text_.empty() && summary_version_ == version && now - summary_time_ < kSummaryMaxAge)
      return summary_text_;
  }
  std::string text = JsonText(Summary());
  std::lock_guard lock(cache_mutex_);
  summary_text_ = text;
  summary_version_ = version;
  summary_time_ = now;
  return text;
}

void StationHttpServer::Publish(const StationRecord& record, const StationCounts&) {
  const double start = ThisThreadsCpuSeconds();
  {
    std::lock_guard lock(mutex_);
    summary_.AddNew(record, std::chrono::system_clock::now());
  }
  ++version_;
  std::lock_guard lock(cpu_mutex_);
  publishing_s_ += ThisThreadsCpuSeconds() - start;
}

void StationHttpServer::PublishImage(const StationRecord& record, const std::string& jpeg) {
  const InspectionRecord& r = record.inspection;
  const bool problem = !r.measured || !r.judgement.pass();
  std::lock_guard lock(mutex_);
  if (last_image_ != 0 && std::find(problem_images_.begin(), problem_images_.end(), last_image_) == problem_images_.end())
    images_.erase(last_image_);
  images_[record.sequence] = jpeg;
  last_image_ = record.sequence;
  if (!problem) return;
  problem_images_.push_back(record.sequence);
  if (problem_images_.size() > kProblemImages) {
    images_.erase(problem_images_.front());
    problem_images_.pop_front();
  }
}

void StationHttpServer::Readiness(bool ready, const std::string& reason, const StationCounts&) {
  std::lock_guard lock(mutex_);
  summary_.SetReadiness(ready, reason);
  ++version_;
}

}  // namespace flatscan
