#pragma once
// SHA-256 (FIPS 180-4), to record which rig, plane and image files a result came from.
#include <cstddef>
#include <filesystem>
#include <string>

namespace flatscan {

// Lower-case hex digest of `data` (OpenSSL's libcrypto: the CPU's SHA instructions).
std::string Sha256Hex(const std::string& data);
std::string Sha256Hex(const void* data, size_t size);
// Of a file's bytes; throws InputError naming the file if it cannot be read.
std::string Sha256HexOfFile(const std::filesystem::path& path);
// True for 64 lower-case hex digits (the form both functions return).
bool IsSha256Hex(const std::string& text);

}  // namespace flatscan
