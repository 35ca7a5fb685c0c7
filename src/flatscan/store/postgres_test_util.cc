#include "flatscan/store/postgres_test_util.h"

#include <libpq-fe.h>
#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace flatscan::testing {
namespace fs = std::filesystem;
namespace {

// The newest installed PostgreSQL's programs (Debian: /usr/lib/postgresql/<major>/bin).
fs::path BinDir() {
  fs::path best;
  int best_major = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    const int major = std::atoi(entry.path().filename().c_str());
    if (major > best_major && fs::exists(entry.path() / "bin" / "postgres")) {
      best_major = major;
      best = entry.path() / "bin";
    }
  }
  return best;
}

bool AsRoot() { return ::geteuid() == 0; }

std::string ReadAll(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

PostgresCluster::PostgresCluster(const std::string& password) : password_(password) {
  static std::atomic<int> count{0};
  dir_ = fs::temp_directory_path() / fmt::format("flatscan-pg-{}-{}", ::getpid(), count++);
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  ::chmod(dir_.c_str(), 0700);
  OwnByServer(dir_);
  port_ = FreeLoopbackPort();
  const fs::path password_file = dir_ / "password";
  std::ofstream(password_file) << password_ << "\n";
  OwnByServer(password_file);
  initialized_ = RunAsOwner("initdb", {"-D", (dir_ / "data").string(), "-U", "flatscan", "--pwfile",
                                       password_file.string(), "-N", "-E", "UTF8", "--locale=C"});
  if (!initialized_) return;
  std::ofstream(dir_ / "data" / "pg_hba.conf") << "local all all trust\n"
                                                  "host all all 127.0.0.1/32 scram-sha-256\n";
  std::ofstream(dir_ / "data" / "postgresql.conf", std::ios::app)
      << "listen_addresses = '127.0.0.1'\nport = " << port_ << "\nunix_socket_directories = '" << dir_.string()
      << "'\nfsync = off\nshared_buffers = 16MB\nmax_connections = 20\n";
}

PostgresCluster::~PostgresCluster() {
  if (server_) {
    server_->Signal(SIGQUIT);  // immediate shutdown: the test is over
    server_->Wait(10);
    server_.reset();
  }
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

fs::path PostgresCluster::UseSelfSignedTls() {
  const fs::path cert = dir_ / "server.crt", key = dir_ / "server.key";
  if (!MakeSelfSignedCertificate(cert, key, dir_ / "openssl.log")) return {};
  ::chmod(key.c_str(), 0600);  // the server refuses a key others may read
  OwnByServer(cert);
  OwnByServer(key);
  std::ofstream(dir_ / "data" / "postgresql.conf", std::ios::app)
      << "ssl = on\nssl_cert_file = '" << cert.string() << "'\nssl_key_file = '" << key.string() << "'\n";
  std::ofstream(dir_ / "data" / "pg_hba.conf") << "local all all trust\n"
                                                  "hostssl all all 127.0.0.1/32 scram-sha-256\n";
  return cert;
}

bool PostgresCluster::Start() {
  if (!initialized_) return false;
  server_ = Spawn("postgres", {"-D", (dir_ / "data").string()});
  return server_->started() && WaitFor([&] { return PQping(Uri("sslmode=prefer").c_str()) == PQPING_OK; }, 30);
}

bool PostgresCluster::Stop() {
  if (!server_) return false;
  server_->Signal(SIGINT);
  const bool stopped = server_->Wait(30) == 0;
  server_.reset();
  return stopped;
}

std::string PostgresCluster::Uri(const std::string& query) const {
  return fmt::format("postgresql://flatscan:{}@127.0.0.1:{}/postgres{}{}", password_, port_, query.empty() ? "" : "?",
                     query);
}

std::string PostgresCluster::Log() const { return ReadAll(dir_ / "initdb.log") + ReadAll(dir_ / "server.log"); }

bool PostgresCluster::RunAsOwner(const std::string& tool, const std::vector<std::string>& args) {
  const auto process = Spawn(tool, args);
  return process->started() && process->Wait(120) == 0;
}

// As root the program runs as 'postgres' (setpriv execs it: the process is the server).
std::unique_ptr<BackgroundProcess> PostgresCluster::Spawn(const std::string& tool,
                                                          const std::vector<std::string>& args) {
  const std::string program = (BinDir() / tool).string();
  const fs::path log = dir_ / (tool == "postgres" ? "server.log" : tool + ".log");
  if (!AsRoot()) return std::make_unique<BackgroundProcess>(program, args, log);
  std::vector<std::string> as_owner = {"--reuid=postgres", "--regid=postgres", "--init-groups", program};
  as_owner.insert(as_owner.end(), args.begin(), args.end());
  return std::make_unique<BackgroundProcess>("setpriv", as_owner, log);
}

void PostgresCluster::OwnByServer(const fs::path& path) const {
  if (!AsRoot()) return;
  if (const passwd* user = ::getpwnam("postgres")) {
    if (::chown(path.c_str(), user->pw_uid, user->pw_gid) != 0) return;  // initdb then says what it cannot do
  }
}

}  // namespace flatscan::testing
