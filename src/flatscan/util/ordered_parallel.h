#pragma once
// Work on many items in parallel, results delivered one at a time in the items' order.
//
// A TBB pipeline: a serial stage hands out the indices 0..count-1, `work` runs on them in
// parallel, and a serial in-order stage calls `deliver` with each result as soon as every
// earlier one has been delivered. At most `max_in_flight` items are between the two
// serial stages at any time, so memory stays bounded whatever `count` is. This is how a
// batch streams its records: measured in parallel, written in input order, each written
// (and flushed) as early as the order allows.
#include <cstddef>
#include <functional>
#include <optional>
#include <utility>

#include <tbb/parallel_pipeline.h>

namespace flatscan {

template <typename Result>
void ParallelInOrder(size_t count, size_t max_in_flight, const std::function<Result(size_t)>& work,
                     const std::function<void(size_t, Result&)>& deliver) {
  if (count == 0) return;
  size_t next = 0;
  tbb::parallel_pipeline(
      max_in_flight,
      tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order,
                                     [&](tbb::flow_control& control) -> size_t {
                                       if (next == count) {
                                         control.stop();
                                         return 0;
                                       }
                                       return next++;
                                     }) &
          tbb::make_filter<size_t, std::pair<size_t, Result>>(
              tbb::filter_mode::parallel, [&](size_t i) { return std::pair<size_t, Result>(i, work(i)); }) &
          tbb::make_filter<std::pair<size_t, Result>, void>(
              tbb::filter_mode::serial_in_order, [&](std::pair<size_t, Result> item) { deliver(item.first, item.second); }));
}

}  // namespace flatscan
