#pragma once
// SHA-256 (FIPS 180-4), to record which rig and plane files a result came from.
#include <filesystem>
#include <string>

namespace flatscan {

// Lower-case hex digest of `data`.
std::string Sha256Hex(const std::string& data);
// Of a file's bytes; throws InputError naming the file if it cannot be read.
std::string Sha256HexOfFile(const std::filesystem::path& path);
// True for 64 lower-case hex digits (the form both functions return).
bool IsSha256Hex(const std::string& text);

}  // namespace flatscan
