#pragma once
// Parse-time checks of the numeric options. CLI11 runs a validator on the option's text
// before converting it; these accept a decimal number only (no hex, no trailing text),
// reject NaN and infinity, check the range, and say so in words a user reads:
//   --tolerance: not a number: 'abc'
//   --tolerance: must be a finite number, got 'nan'
//   --tolerance: must be in (0, 10], got 12
//   --parts: must be a whole number in [1, 1000], got 2.5
// (CLI11's own CLI::PositiveNumber lets NaN through, and CLI::Range prints an unbounded
// end as a 300-digit 1.8e308.)
#include <string>

#include <CLI/CLI.hpp>

namespace flatscan {

// A real number in [min, max], or (min, max] when `min_open`.
CLI::Validator RealIn(double min, double max, bool min_open = false);
// A real number in (0, max].
inline CLI::Validator PositiveReal(double max) { return RealIn(0, max, true); }
// A whole number in [min, max] ("1e3" and "2.0" are not whole numbers as written).
CLI::Validator IntegerIn(long long min, long long max);

}  // namespace flatscan
