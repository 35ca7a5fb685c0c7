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

// The file's inode number; 0 when there is no such file.
ino_t InodeOf(const fs::path& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? st.st_ino : 0;
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
      ::poll(&p, 1, int(std::clamp<int64_t>(timeout.count(), 0, 60'000)));
      lock.lock();
      Update();
    }
    if (ready_.empty()) return std::nullopt;
    SourcePair pair = std::move(ready_.front());
    ready_.pop_front();
    return pair;
  }

  bool Exhausted() const override { return false; }
  std::string Name() const override { return "folder:" + dir_.string(); }

  // Moves the pair's files to done/: hard links first (done/ then holds both), then the
  // originals removed, right before left; a restart recognises a file whose done/ copy
  // is the same file as a move to finish. Only the very files handed out are moved (the
  // same inodes): a file delivered again under the id meanwhile stays, and counts now.
  void Done(const SourcePair& pair) override {
    const std::lock_guard lock(mutex_);
    const auto claimed = claimed_.find(pair.source_id);
    if (claimed == claimed_.end()) return;
    const Inodes inodes = claimed->second;
    claimed_.erase(claimed);
    MoveToDone(pair.source_id, inodes);
    RememberDone(pair.source_id);
    const std::vector<std::string> deferred = std::move(deferred_[pair.source_id]);
    deferred_.erase(pair.source_id);
    for (const std::string& name : deferred) Complete(name);
  }

 private:
  struct Inodes {
    ino_t left = 0, right = 0;  // 0: no file on that side
  };
  struct Pending {
    Inodes inodes;
    Clock::time_point first_seen;
  };

  void MoveToDone(const std::string& id, const Inodes& inodes) {
    const fs::path left = Path(id, Side::kLeft), right = Path(id, Side::kRight);
    const bool move_left = inodes.left != 0 && InodeOf(left) == inodes.left && LinkIntoDone(left);
    const bool move_right = inodes.right != 0 && InodeOf(right) == inodes.right && LinkIntoDone(right);
    if (move_right) ::unlink(right.c_str());
    if (move_left) ::unlink(left.c_str());
  }

  // A pair goes out: its files' inodes are what Done() will move.
  void Hand(const std::string& id, const Inodes& inodes, std::optional<std::string> not_measurable) {
    claimed_[id] = inodes;
    ready_.push_back(FilePair(id, Path(id, Side::kLeft), Path(id, Side::kRight), std::move(not_measurable)));
  }

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
          unsettled_.erase(e->name);  // closed or renamed in: complete now
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
        Hand(it->first, it->second.inodes, HalfPairReason(it->first, it->second.inodes));
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }

  std::string HalfPairReason(const std::string& id, const Inodes& inodes) const {
    const Side present = inodes.left ? Side::kLeft : Side::kRight, missing = inodes.left ? Side::kRight : Side::kLeft;
    return fmt::format("half pair: the {} image {} did not arrive within {:.1f} s of the {} image {}",
                       missing == Side::kLeft ? "left" : "right", Path(id, missing).string(),
                       std::chrono::duration<double>(options_.half_pair_timeout).count(),
                       present == Side::kLeft ? "left" : "right", Path(id, present).string());
  }

  // A file of the folder is complete (an event, a settled file, a rescan). The same file
  // reported twice counts once; another file under the id of a pair that is out (queued
  // or being measured) waits until that pair is done.
  void Complete(const std::string& name) {
    const auto parsed = ParseName(name);
    if (!parsed) return;
    const auto& [id, side] = *parsed;
    const ino_t inode = InodeOf(dir_ / name);
    if (inode == 0) return;  // gone since (moved to done/, deleted)
    if (const auto out = claimed_.find(id); out != claimed_.end()) {
      if ((side == Side::kLeft ? out->second.left : out->second.right) != inode) deferred_[id].push_back(name);
      return;
    }
    Pending& p = pending_[id];
    if (!p.inodes.left && !p.inodes.right) p.first_seen = Clock::now();
    (side == Side::kLeft ? p.inodes.left : p.inodes.right) = inode;
    if (p.inodes.left && p.inodes.right) {
      Hand(id, p.inodes, std::nullopt);
      pending_.erase(id);
    }
  }

  // The folder's files (at start-up, or again after an inotify overflow): files not
  // modified for `settle` count at once, newer ones when they close or settle.
  void Scan(bool at_start) {
    if (at_start) FinishInterruptedMoves();
    std::vector<std::pair<fs::file_time_type, std::string>> files;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      if (!entry.is_regular_file() || !ParseName(name)) continue;
      std::error_code ec;
      files.emplace_back(fs::last_write_time(entry.path(), ec), name);
    }
    std::sort(files.begin(), files.end());  // oldest first: pairs in the order they came
    const auto now = fs::file_time_type::clock::now();
    for (const auto& [time, name] : files) {
      if (now - time < options_.settle) unsettled_.insert(name);
      else Complete(name);
    }
  }

  // A file in the folder that is the same file as its done/ copy belongs to a pair whose
  // record was committed and whose move a kill interrupted: both its files go to done/
  // (the partner may not have been linked yet).
  void FinishInterruptedMoves() {
    std::set<std::string> ids;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      const auto parsed = ParseName(name);
      if (parsed && entry.is_regular_file() && SameFile(entry.path(), done_ / name)) ids.insert(parsed->first);
    }
    for (const std::string& id : ids) {
      spdlog::info("{}: finishing the move of pair {} to done/ (interrupted)", Name(), id);
      MoveToDone(id, {InodeOf(Path(id, Side::kLeft)), InodeOf(Path(id, Side::kRight))});
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
  std::map<std::string, Inodes> claimed_;  // pairs out (queued or being measured): their files
  std::map<std::string, std::vector<std::string>> deferred_;  // files that came for a pair that is out
  std::deque<SourcePair> ready_;
  std::deque<std::string> done_order_;
};

}  // namespace

std::unique_ptr<PairSource> MakeFolderSource(const fs::path& dir, const FolderSourceOptions& options) {
  return std::make_unique<FolderSource>(dir, options);
}

}  // namespace flatscan
