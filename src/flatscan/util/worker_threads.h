#pragma once

#include <new>

#include <oneapi/tbb/global_control.h>
#include <opencv2/core/utility.hpp>

namespace flatscan {

// Joins TBB's worker threads (OpenCV's parallel loops share them) when it goes out of
// scope, so that no worker is still winding down while the process runs its exit
// handlers. Why: LeakSanitizer's leak check at exit stops every thread with ptrace, and
// a thread that is exiting at that moment can crash its tracer ("Tracer caught signal 11",
// google/sanitizers#1353): a passing test then fails the sanitizer build. Construct one at
// the top of main(). OpenCV keeps its own task arena alive, which makes TBB refuse to
// finalize (measured: finalize returned false after one cv::parallel_for_); switching
// OpenCV to sequential mode (setNumThreads(0)) releases it, after which finalize waits
// for every worker. The nothrow form returns false instead of throwing if some other
// scheduler reference is still alive (then nothing is waited for).
class JoinWorkerThreadsAtExit {
 public:
  JoinWorkerThreadsAtExit() : handle_(oneapi::tbb::attach{}) {}
  ~JoinWorkerThreadsAtExit() {
    cv::setNumThreads(0);
    oneapi::tbb::finalize(handle_, std::nothrow);
  }
  JoinWorkerThreadsAtExit(const JoinWorkerThreadsAtExit&) = delete;
  JoinWorkerThreadsAtExit& operator=(const JoinWorkerThreadsAtExit&) = delete;

 private:
  oneapi::tbb::task_scheduler_handle handle_;
};

}  // namespace flatscan
