#pragma once
// The project's one content hash, SHA-256, and the keyed MAC of cache files, HMAC-SHA256 (both
// from OpenSSL's libcrypto).
#include <array>
#include <cstddef>
#include <string>
#include <string_view>

namespace distlab::kelvin {

using Digest = std::array<unsigned char, 32>;

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void add(const void* data, std::size_t size);
  Digest digest();    // ends the stream
  std::string hex();  // digest() as 64 lower-case hex digits

 private:
  void* ctx_;  // EVP_MD_CTX
};

// HMAC-SHA256 over data given in pieces (a cache entry as it is written).
class HmacSha256 {
 public:
  explicit HmacSha256(std::string_view key);
  ~HmacSha256();
  HmacSha256(const HmacSha256&) = delete;
  HmacSha256& operator=(const HmacSha256&) = delete;
  void add(const void* data, std::size_t size);
  Digest digest();  // ends the stream

 private:
  void* mac_;  // EVP_MAC
  void* ctx_;  // EVP_MAC_CTX
};

Digest hmac_sha256(std::string_view key, std::string_view data);
// Constant-time comparison (a MAC check must not leak how many leading bytes matched).
bool same_digest(const Digest& a, const Digest& b);

}  // namespace distlab::kelvin
