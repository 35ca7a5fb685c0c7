#pragma once
// Test helper for the plant store: a throwaway PostgreSQL cluster (initdb) served on a
// loopback port by a postgres process the test starts and stops. Tests run as root,
// which PostgreSQL refuses: as root the cluster belongs to the user 'postgres' (the
// server package creates it) and its programs run as that user (setpriv).
#include <filesystem>
#include <memory>
#include <string>

#include "flatscan/util/test_util.h"

namespace flatscan::testing {

class PostgresCluster {
 public:
  // A new cluster in a folder of its own (removed by the destructor, which also stops
  // the server) with superuser `flatscan`, password `password`: TCP connections must
  // give it (scram-sha-256). initialized() says whether initdb worked (its log: log()).
  explicit PostgresCluster(const std::string& password);
  ~PostgresCluster();
  PostgresCluster(const PostgresCluster&) = delete;
  PostgresCluster& operator=(const PostgresCluster&) = delete;

  bool initialized() const { return initialized_; }
  // Only TLS connections are then accepted, with a self-signed certificate for
  // 127.0.0.1 made here; its path (the CA a client trusts) is returned, or "" on failure.
  std::filesystem::path UseSelfSignedTls();
  // Starts the server and waits (at most 30 s) until it answers.
  bool Start();
  // A fast shutdown (SIGINT: sessions are ended, the server exits); waits at most 30 s.
  bool Stop();
  // postgresql://flatscan:<password>@127.0.0.1:<port>/postgres, then `query` (after '?').
  std::string Uri(const std::string& query = "") const;
  // The server's log and initdb's output.
  std::string Log() const;
  int port() const { return port_; }

 private:
  std::string Tool(const std::string& name) const;
  bool RunAsOwner(const std::string& tool, const std::vector<std::string>& args);
  std::unique_ptr<BackgroundProcess> Spawn(const std::string& tool, const std::vector<std::string>& args);
  void OwnByServer(const std::filesystem::path& path) const;

  std::filesystem::path dir_;
  std::string password_;
  int port_ = 0;
  bool initialized_ = false;
  std::unique_ptr<BackgroundProcess> server_;
};

}  // namespace flatscan::testing
