#include "flatscan/station/folder_source.h"

#include <poll.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kLeftSuffix = "_left.png";
constexpr const char* kRightSuffix = "_right.png";

enum class Side { kLeft, kRight };

// The pair id and side a file name stands for; nullopt for any other file.
std::optional<std::pair<std::string, Side>> ParseName(const std::string& name) {
  if (name.empty() || name.front() == '.') return std::nullopt;
  for (const auto& [suffix, side] : {std::pair{kLeftSuffix, Side::kLeft}, std::pair{kRightSuffix, Side::kRight}}) {
    const size_t n = std::strlen(suffix);
    if (name.size() > n && name.compare(name.size() - n, n, suffix) == 0)
      return std::pair{name.substr(0, name.size() - n), side};
  }
  return std::nullopt;
}

bool SameFile(const fs::path& a, const fs::path& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

class FolderSource : public PairSource {
 public:
  FolderSource(fs::path dir, const FolderSourceOptions& options)
      : dir_(std::move(dir)), done_(dir_ / "done"), options_(options) {
    std::error_code ec;
    if (!fs::is_directory(dir_, ec)) ThrowInputError("--source folder:{}: no such folder", dir_.string());
    fs::create_directories(done_, ec);
    if (ec) ThrowInputError("--source folder:{}: cannot create {} ({})", dir_.string(), done_.string(), ec.message());
    fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd_ < 0 || inotify_add_watch(fd_, dir_.c_str(), IN_CLOSE_WRITE | IN_MOVED_TO) < 0) {
      const std::string reason = std::strerror(errno);
      if (fd_ >= 0) ::close(fd_);
      ThrowInputError("--source folder:{}: cannot watch the folder ({})", dir_.string(), reason);
    }
    LoadDone();
    Scan(/*at_start=*/true);
  }
  ~FolderSource() override { ::close(fd_); }

  std::optional<SourcePair> Next(std::chrono::milliseconds wait) override {
    std::unique_lock lock(mutex_);
    Update();
    if (ready_.empty()) {
      const std::chrono::milliseconds timeout = std::min(wait, TimeToNextDeadline());
      lock.unlock();  // Done() may run while this waits
      pollfd p{fd_, POLLIN, 0};
      ::poll(&p, 1, int(timeout.count()));
      lock.lock();
      Update();
    }
    if (ready_.empty()) return std::nullopt;
    SourcePair pair = std::move(ready_.front());
    ready_.pop_front();
    in_flight_.insert(pair.source_id);
    return pair;
  }

  bool Exhausted() const override { return false; }
  std::string Name() const override { return "folder:" + dir_.string(); }

  // Moves the pair's files to done/: hard links first (done/ then holds both), then the
  // originals removed, right before left; a restart recognises a file whose done/ copy
  // is the same file as a move to finish.
  void Done(const SourcePair& pair) override {
    const std::lock_guard lock(mutex_);
    in_flight_.erase(pair.source_id);
    const bool left = LinkIntoDone(pair.left), right = LinkIntoDone(pair.right);
    if (right) ::unlink(pair.right.c_str());
    if (left) ::unlink(pair.left.c_str());
    RememberDone(pair.source_id);
  }

 private:
  struct Pending {
    bool left = false, right = false;
    Clock::time_point first_seen;
  };

  fs::path Path(const std::string& id, Side side) const {
    return dir_ / (id + (side == Side::kLeft ? kLeftSuffix : kRightSuffix));
  }

  // Reads the inotify events that are there (never blocks), then settles start-up files
  // and times out half pairs.
  void Update() {
    alignas(inotify_event) char buffer[16384];
    for (;;) {
      const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
      if (n <= 0) break;
      for (ssize_t at = 0; at < n;) {
        const auto* e = reinterpret_cast<const inotify_event*>(buffer + at);
        if (e->mask & IN_Q_OVERFLOW) {
          spdlog::warn("{}: more files arrived than inotify could queue; rescanning the folder", Name());
          Scan(false);
        } else if (e->len > 0) {
          Complete(e->name);
        }
        at += ssize_t(sizeof(inotify_event) + e->len);
      }
    }
    const auto now = Clock::now();
    for (auto it = unsettled_.begin(); it != unsettled_.end();) {
      std::error_code ec;
      const auto age = fs::file_time_type::clock::now() - fs::last_write_time(dir_ / *it, ec);
      if (ec) {
        it = unsettled_.erase(it);  // gone
      } else if (age >= options_.settle) {
        Complete(*it);
        it = unsettled_.erase(it);
      } else {
        ++it;
      }
    }
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (now - it->second.first_seen >= options_.half_pair_timeout) {
        ready_.push_back(HalfPair(it->first, it->second));
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }

  SourcePair HalfPair(const std::string& id, const Pending& p) const {
    const Side present = p.left ? Side::kLeft : Side::kRight, missing = p.left ? Side::kRight : Side::kLeft;
    const std::string reason =
        fmt::format("half pair: the {} image {} did not arrive within {:.1f} s of the {} image {}",
                    missing == Side::kLeft ? "left" : "right", Path(id, missing).string(),
                    std::chrono::duration<double>(options_.half_pair_timeout).count(),
                    present == Side::kLeft ? "left" : "right", Path(id, present).string());
    return SourcePair{id, Path(id, Side::kLeft), Path(id, Side::kRight), reason};
  }

  // A file of the folder is complete.
  void Complete(const std::string& name) {
    const auto parsed = ParseName(name);
    if (!parsed || in_flight_.count(parsed->first)) return;
    const auto& [id, side] = *parsed;
    Pending& p = pending_[id];
    if (!p.left && !p.right) p.first_seen = Clock::now();
    (side == Side::kLeft ? p.left : p.right) = true;
    if (p.left && p.right) {
      ready_.push_back(SourcePair{id, Path(id, Side::kLeft), Path(id, Side::kRight), std::nullopt});
      pending_.erase(id);
    }
  }

  // The folder's files: at start-up, files not modified for `settle` count at once,
  // newer ones when they settle (or close); a rescan after an overflow takes every file.
  void Scan(bool at_start) {
    std::vector<std::pair<fs::file_time_type, std::string>> files;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      if (!entry.is_regular_file() || !ParseName(name)) continue;
      if (at_start && SameFile(entry.path(), done_ / name)) {  // a move that a kill interrupted
        ::unlink(entry.path().c_str());
        continue;
      }
      std::error_code ec;
      files.emplace_back(fs::last_write_time(entry.path(), ec), name);
    }
    std::sort(files.begin(), files.end());  // oldest first: pairs in the order they came
    const auto now = fs::file_time_type::clock::now();
    for (const auto& [time, name] : files) {
      if (at_start && now - time < options_.settle) unsettled_.insert(name);
      else Complete(name);
    }
  }

  std::chrono::milliseconds TimeToNextDeadline() const {
    auto next = std::chrono::milliseconds::max();
    if (!unsettled_.empty()) next = std::chrono::milliseconds(50);
    const auto now = Clock::now();
    for (const auto& [id, p] : pending_) {
      const auto left = options_.half_pair_timeout - (now - p.first_seen);
      next = std::min(next, std::max(std::chrono::milliseconds(0),
                                     std::chrono::duration_cast<std::chrono::milliseconds>(left)));
    }
    return next;
  }

  // done/<name> becomes the file (replacing an older pair of the same id); whether it
  // did, so that the original may go. A file that is not there (the missing half of a
  // pair) is not an error; one that cannot be linked stays where it is.
  bool LinkIntoDone(const fs::path& file) {
    const fs::path target = done_ / file.filename(), tmp = done_ / fmt::format(".{}.link", file.filename().string());
    ::unlink(tmp.c_str());
    if (::link(file.c_str(), tmp.c_str()) != 0) {
      if (errno != ENOENT)
        spdlog::warn("{}: cannot move {} to {} ({}); it stays", Name(), file.string(), done_.string(),
                     std::strerror(errno));
      return false;
    }
    if (::rename(tmp.c_str(), target.c_str()) != 0) {
      spdlog::warn("{}: cannot move {} to {} ({}); it stays", Name(), file.string(), target.string(),
                   std::strerror(errno));
      ::unlink(tmp.c_str());
      return false;
    }
    return true;
  }

  // done/ keeps the newest keep_done pairs.
  void RememberDone(const std::string& id) {
    done_order_.erase(std::remove(done_order_.begin(), done_order_.end(), id), done_order_.end());
    done_order_.push_back(id);
    while (done_order_.size() > size_t(options_.keep_done)) {
      for (const char* suffix : {kLeftSuffix, kRightSuffix}) ::unlink((done_ / (done_order_.front() + suffix)).c_str());
      done_order_.pop_front();
    }
  }

  // The pairs in done/, oldest first (by their newest file).
  void LoadDone() {
    std::map<std::string, fs::file_time_type> newest;
    for (const auto& entry : fs::directory_iterator(done_)) {
      const auto parsed = ParseName(entry.path().filename().string());
      if (!parsed) continue;
      std::error_code ec;
      const auto time = fs::last_write_time(entry.path(), ec);
      auto [it, added] = newest.emplace(parsed->first, time);
      if (!added) it->second = std::max(it->second, time);
    }
    std::vector<std::pair<fs::file_time_type, std::string>> ids;
    for (const auto& [id, time] : newest) ids.emplace_back(time, id);
    std::sort(ids.begin(), ids.end());
    for (const auto& [time, id] : ids) done_order_.push_back(id);
  }

  fs::path dir_, done_;
  FolderSourceOptions options_;
  int fd_ = -1;
  std::mutex mutex_;  // Next() and Done() run on different threads
  std::map<std::string, Pending> pending_;
  std::set<std::string> unsettled_;
  std::set<std::string> in_flight_;
  std::deque<SourcePair> ready_;
  std::deque<std::string> done_order_;
};

}  // namespace

std::unique_ptr<PairSource> MakeFolderSource(const fs::path& dir, const FolderSourceOptions& options) {
  return std::make_unique<FolderSource>(dir, options);
}

}  // namespace flatscan
