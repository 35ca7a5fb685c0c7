#include "flatscan/outputs/http_server.h"

#include <httplib.h>

#include <chrono>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// The page: plain HTML and a script that polls /api/summary (nothing loaded from elsewhere).
constexpr const char* kPage = R"html(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>flatscan station</title>
<style>body{font-family:sans-serif;margin:24px}#verdict{font-size:72px;font-weight:bold}
.pass{color:#080}.fail{color:#c00}.none{color:#888}td,th{padding:4px 12px;text-align:left}</style></head>
<body><h1 id="station">flatscan station</h1>
<div id="verdict" class="none">-</div><div id="part"></div>
<table><tr><th>measured</th><th>pass</th><th>fail</th><th>marginal</th><th>not measured</th><th>yield</th></tr>
<tr><td id="measured">0</td><td id="pass">0</td><td id="fail">0</td><td id="marginal">0</td>
<td id="not_measured">0</td><td id="yield">-</td></tr></table><p id="state"></p>
<script>
function show(s) {
  document.getElementById('station').textContent = 'flatscan station ' + s.station_id;
  for (const k of ['measured', 'pass', 'fail', 'marginal', 'not_measured'])
    document.getElementById(k).textContent = s.counts[k];
  document.getElementById('yield').textContent =
      s.counts.measured ? (100 * s.counts.pass / s.counts.measured).toFixed(1) + '%' : '-';
  document.getElementById('state').textContent = s.state === 'ready' ? '' : 'station not ready';
  const v = document.getElementById('verdict'), p = document.getElementById('part');
  if (!s.last) return;
  const r = s.last;
  v.textContent = r.measured ? r.verdict.toUpperCase() : 'NOT MEASURED';
  v.className = r.measured ? r.verdict : 'none';
  p.textContent = r.source_id + ': ' + (r.measured
      ? 'flatness ' + r.flatness_mm.toFixed(4) + ' mm, tolerance ' + r.tolerance_mm.toFixed(3) + ' mm'
      : r.error);
}
function poll() {
  fetch('/api/summary').then(r => r.json()).then(show).catch(() => {}).finally(() => setTimeout(poll, 1000));
}
poll();
</script></body></html>
)html";

}  // namespace

void SummaryCounts::Add(const StationRecord& record) {
  const InspectionRecord& r = record.inspection;
  if (!r.measured) {
    ++not_measured;
    return;
  }
  ++measured;
  (r.judgement.pass() ? pass : fail) += 1;
  marginal += r.judgement.marginal;
}

StationHttpServer::StationHttpServer(const std::string& address, int port, std::string station_id,
                                     SummaryCounts counts, std::optional<StationRecord> last)
    : server_(std::make_unique<httplib::Server>()),
      station_id_(std::move(station_id)),
      counts_(counts),
      last_(std::move(last)) {
  server_->Get("/", [](const httplib::Request&, httplib::Response& res) { res.set_content(kPage, "text/html"); });
  server_->Get("/api/summary", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(Summary().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), "application/json");
  });
  server_->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (res.status == 404)
      res.set_content("not found: " + req.path + " (the station serves / and /api/summary)\n", "text/plain");
  });
  // SO_REUSEADDR only: cpp-httplib also sets SO_REUSEPORT, with which a second station on
  // the same port would share it silently instead of being refused.
  server_->set_socket_options([](socket_t socket) {
    const int yes = 1;
    setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  port_ = port == 0 ? server_->bind_to_any_port(address) : (server_->bind_to_port(address, port) ? port : -1);
  if (port_ < 0) ThrowInputError("--http {}:{}: cannot listen there (in use, or not an address of this machine)", address, port);
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  // A stop() before the listening loop runs would be lost (and the destructor's join wait
  // for ever): return once it runs.
  while (!server_->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

StationHttpServer::~StationHttpServer() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

nlohmann::json StationHttpServer::Summary() const {
  std::lock_guard lock(mutex_);
  return {{"station_id", station_id_},
          {"state", ready_ ? "ready" : "not_ready"},
          {"counts",
           {{"measured", counts_.measured},
            {"pass", counts_.pass},
            {"fail", counts_.fail},
            {"marginal", counts_.marginal},
            {"not_measured", counts_.not_measured}}},
          {"last", last_ ? StationRecordToJson(*last_) : nlohmann::json(nullptr)}};
}

void StationHttpServer::Publish(const StationRecord& record, const StationCounts&) {
  std::lock_guard lock(mutex_);
  counts_.Add(record);
  last_ = record;
}

void StationHttpServer::Readiness(bool ready, const std::string&, const StationCounts&) {
  std::lock_guard lock(mutex_);
  ready_ = ready;
}

}  // namespace flatscan
