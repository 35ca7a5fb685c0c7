#pragma once
// A source that hands out a pair only when triggered: one trigger, one pair (`flatscan
// station --trigger software`: the PLC triggers through the Modbus register map). With cameras
// the trigger is the capture; with a replay or a folder it releases the next pair, so that
// a PLC's handshake can be commissioned and tested before the cameras are there.
#include <condition_variable>
#include <cstddef>
#include <mutex>

#include "flatscan/station/pair_source.h"

namespace flatscan {

class TriggeredSource : public PairSource {
 public:
  explicit TriggeredSource(PairSource& inner) : inner_(inner) {}
  // One more pair may be taken (any thread). A trigger that finds no pair waits for the
  // next one the source gives.
  void Trigger();
  // Triggers not yet served by a pair.
  size_t Waiting() const;

  // The next pair once a trigger allows it, waiting at most `wait` for the trigger and
  // then at most `wait` for the pair.
  std::optional<SourcePair> Next(std::chrono::milliseconds wait) override;
  bool Exhausted() const override { return inner_.Exhausted(); }
  void Done(const SourcePair& pair) override { inner_.Done(pair); }
  std::string Name() const override { return inner_.Name() + " (triggered)"; }

 private:
  PairSource& inner_;
  mutable std::mutex mutex_;
  std::condition_variable triggered_;
  size_t waiting_ = 0;
};

}  // namespace flatscan
