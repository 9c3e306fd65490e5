// SHA-256 and HMAC-SHA256 through OpenSSL (digest.hpp).
#include "distlab/kelvin/digest.hpp"

#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/params.h>

#include <cstdio>
#include <stdexcept>

namespace distlab::kelvin {

Sha256::Sha256() : ctx_(EVP_MD_CTX_new()) {
  if (ctx_ == nullptr || EVP_DigestInit_ex(static_cast<EVP_MD_CTX*>(ctx_), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("OpenSSL: cannot start a SHA-256 digest");
}

Sha256::~Sha256() { EVP_MD_CTX_free(static_cast<EVP_MD_CTX*>(ctx_)); }

void Sha256::add(const void* data, std::size_t size) {
  if (EVP_DigestUpdate(static_cast<EVP_MD_CTX*>(ctx_), data, size) != 1)
    throw std::runtime_error("OpenSSL: SHA-256 update failed");
}

Digest Sha256::digest() {
  Digest out{};
  unsigned int n = 0;
  if (EVP_DigestFinal_ex(static_cast<EVP_MD_CTX*>(ctx_), out.data(), &n) != 1 || n != out.size())
    throw std::runtime_error("OpenSSL: SHA-256 final failed");
  return out;
}

std::string Sha256::hex() {
  const Digest d = digest();
  std::string out(2 * d.size(), '0');
  for (std::size_t i = 0; i < d.size(); ++i) std::snprintf(&out[2 * i], 3, "%02x", d[i]);
  return out;
}

HmacSha256::HmacSha256(std::string_view key) : mac_(EVP_MAC_fetch(nullptr, "HMAC", nullptr)), ctx_(nullptr) {
  char digest[] = "SHA256";
  const OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string(OSSL_MAC_PARAM_DIGEST, digest, 0), OSSL_PARAM_construct_end()};
  if (mac_ != nullptr) ctx_ = EVP_MAC_CTX_new(static_cast<EVP_MAC*>(mac_));
  if (ctx_ == nullptr ||
      EVP_MAC_init(static_cast<EVP_MAC_CTX*>(ctx_), reinterpret_cast<const unsigned char*>(key.data()), key.size(), params) != 1) {
    EVP_MAC_CTX_free(static_cast<EVP_MAC_CTX*>(ctx_));
    EVP_MAC_free(static_cast<EVP_MAC*>(mac_));
    throw std::runtime_error("OpenSSL: cannot start an HMAC-SHA256");
  }
}

HmacSha256::~HmacSha256() {
  EVP_MAC_CTX_free(static_cast<EVP_MAC_CTX*>(ctx_));
  EVP_MAC_free(static_cast<EVP_MAC*>(mac_));
}

void HmacSha256::add(const void* data, std::size_t size) {
  if (EVP_MAC_update(static_cast<EVP_MAC_CTX*>(ctx_), static_cast<const unsigned char*>(data), size) != 1)
    throw std::runtime_error("OpenSSL: HMAC-SHA256 update failed");
}

Digest HmacSha256::digest() {
  Digest out{};
  std::size_t n = 0;
  if (EVP_MAC_final(static_cast<EVP_MAC_CTX*>(ctx_), out.data(), &n, out.size()) != 1 || n != out.size())
    throw std::runtime_error("OpenSSL: HMAC-SHA256 final failed");
  return out;
}

Digest hmac_sha256(std::string_view key, std::string_view data) {
  HmacSha256 mac(key);
  mac.add(data.data(), data.size());
  return mac.digest();
}

bool same_digest(const Digest& a, const Digest& b) { return CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0; }

}  // namespace distlab::kelvin
