#include "flatscan/util/sha256.h"

#include <array>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <openssl/evp.h>

#include "flatscan/util/error.h"

namespace flatscan {

// OpenSSL's libcrypto picks the CPU's SHA instructions where there are any (SHA-NI,
// ARMv8): about 2 GB/s against 0.2 GB/s for the portable code this replaced, which took
// 26 ms for a 5 MP image.
std::string Sha256Hex(const void* data, size_t size) {
  std::array<unsigned char, 32> digest{};
  unsigned int length = 0;
  FLATSCAN_CHECK(EVP_Digest(data, size, digest.data(), &length, EVP_sha256(), nullptr) == 1);
  FLATSCAN_CHECK(length == digest.size());
  std::string out;
  out.reserve(64);
  for (unsigned char byte : digest) out += fmt::format("{:02x}", byte);
  return out;
}

std::string Sha256Hex(const std::string& data) { return Sha256Hex(data.data(), data.size()); }

std::string Sha256HexOfFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError("{}: cannot read file", path.string());
  std::stringstream s;
  s << in.rdbuf();
  return Sha256Hex(s.str());
}

bool IsSha256Hex(const std::string& text) {
  return text.size() == 64 && text.find_first_not_of("0123456789abcdef") == std::string::npos;
}

}  // namespace flatscan
