// OpenSSL 3 helpers; see openssl_util.hpp.
#include "dds/security/openssl_util.hpp"

#include <cstdio>
#include <ctime>
#include <fstream>
#include <iterator>

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509_vfy.h>

namespace teamscan::dds::security {

bool read_file(const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

namespace {
BioPtr bio_of_file(const std::string& path, std::string& buffer) {
  if (!read_file(path, buffer)) return nullptr;
  return BioPtr{BIO_new_mem_buf(buffer.data(), static_cast<int>(buffer.size()))};
}
int no_password(char* /*buf*/, int /*size*/, int /*rwflag*/, void* /*u*/) { return -1; }
}  // namespace

X509Ptr read_cert(const std::string& path) {
  std::string buf;
  BioPtr bio = bio_of_file(path, buf);
  if (!bio) return nullptr;
  X509Ptr p{PEM_read_bio_X509(bio.get(), nullptr, no_password, nullptr)};
  ERR_clear_error();
  return p;
}

EvpKeyPtr read_private_key(const std::string& path) {
  std::string buf;
  BioPtr bio = bio_of_file(path, buf);
  if (!bio) return nullptr;
  EvpKeyPtr p{PEM_read_bio_PrivateKey(bio.get(), nullptr, no_password, nullptr)};
  ERR_clear_error();
  return p;
}

X509CrlPtr read_crl(const std::string& path) {
  std::string buf;
  BioPtr bio = bio_of_file(path, buf);
  if (!bio) return nullptr;
  X509CrlPtr p{PEM_read_bio_X509_CRL(bio.get(), nullptr, no_password, nullptr)};
  ERR_clear_error();
  return p;
}

std::string openssl_error() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "unknown OpenSSL error";
  char buf[256];
  ERR_error_string_n(e, buf, sizeof buf);
  return buf;
}

std::string key_type_problem(EVP_PKEY* key) {
  if (key == nullptr) return "no public key";
  const int id = EVP_PKEY_get_base_id(key);
  if (id == EVP_PKEY_EC) {
    char group[64] = {0};
    size_t len = 0;
    if (EVP_PKEY_get_group_name(key, group, sizeof group, &len) != 1) return "EC key without a named curve";
    const std::string g = group;
    if (g == "prime256v1" || g == "P-256") return {};
    return "EC curve " + g + " is refused by the Cyclone 0.10.2 plugins (P-256 only)";
  }
  if (id == EVP_PKEY_RSA) {
    if (EVP_PKEY_get_bits(key) == 2048) return {};
    return "RSA-" + std::to_string(EVP_PKEY_get_bits(key)) + " is refused by the Cyclone 0.10.2 plugins (RSA-2048 only)";
  }
  return "key type is neither EC P-256 nor RSA-2048";
}

std::string subject_rfc2253(X509* cert) {
  BioPtr bio{BIO_new(BIO_s_mem())};
  X509_NAME_print_ex(bio.get(), X509_get_subject_name(cert), 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

std::string common_name(X509* cert) {
  char buf[256] = {0};
  if (X509_NAME_get_text_by_NID(X509_get_subject_name(cert), NID_commonName, buf, sizeof buf) < 0) return {};
  return buf;
}

std::int64_t asn1_time_to_unix(const ASN1_TIME* t) {
  std::tm tm{};
  if (t == nullptr || ASN1_TIME_to_tm(t, &tm) != 1) return 0;
  return static_cast<std::int64_t>(timegm(&tm));
}

std::string unix_to_utc(std::int64_t t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

namespace {
struct StoreFree { void operator()(X509_STORE* p) const { X509_STORE_free(p); } };
struct StoreCtxFree { void operator()(X509_STORE_CTX* p) const { X509_STORE_CTX_free(p); } };
using StorePtr = std::unique_ptr<X509_STORE, StoreFree>;

StorePtr make_store(X509* ca, X509_CRL* crl, std::int64_t now_s) {
  StorePtr store{X509_STORE_new()};
  X509_STORE_add_cert(store.get(), ca);
  X509_VERIFY_PARAM* param = X509_STORE_get0_param(store.get());
  X509_VERIFY_PARAM_set_time(param, static_cast<time_t>(now_s));
  if (crl != nullptr) {
    X509_STORE_add_crl(store.get(), crl);
    X509_VERIFY_PARAM_set_flags(param, X509_V_FLAG_CRL_CHECK);
  }
  return store;
}
}  // namespace

std::string verify_cert(X509* cert, X509* ca, X509_CRL* crl, std::int64_t now_s) {
  StorePtr store = make_store(ca, crl, now_s);
  std::unique_ptr<X509_STORE_CTX, StoreCtxFree> ctx{X509_STORE_CTX_new()};
  if (X509_STORE_CTX_init(ctx.get(), store.get(), cert, nullptr) != 1) return openssl_error();
  if (X509_verify_cert(ctx.get()) == 1) return {};
  const int err = X509_STORE_CTX_get_error(ctx.get());
  ERR_clear_error();
  std::string why = X509_verify_cert_error_string(err);
  if (err == X509_V_ERR_CERT_HAS_EXPIRED)
    why += " on " + unix_to_utc(asn1_time_to_unix(X509_get0_notAfter(cert)));
  else if (err == X509_V_ERR_CERT_NOT_YET_VALID)
    why += " before " + unix_to_utc(asn1_time_to_unix(X509_get0_notBefore(cert))) + " (check this host's clock)";
  else if (err == X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT_LOCALLY || err == X509_V_ERR_CERT_SIGNATURE_FAILURE)
    why += ": not issued by this site's CA";
  return why;
}

std::string verify_smime_file(const std::string& path, X509* ca, std::int64_t now_s, std::string& content) {
  std::string buf;
  BioPtr in = bio_of_file(path, buf);
  if (!in) return "missing or unreadable";
  BIO* detached = nullptr;
  Pkcs7Ptr p7{SMIME_read_PKCS7(in.get(), &detached)};
  BioPtr detached_owner{detached};
  if (!p7) {
    ERR_clear_error();
    return "not an S/MIME signed document (sign it with the site CA: teamscan pki)";
  }
  StorePtr store = make_store(ca, nullptr, now_s);
  BioPtr out{BIO_new(BIO_s_mem())};
  if (PKCS7_verify(p7.get(), nullptr, store.get(), detached, out.get(), PKCS7_TEXT) != 1) {
    return "signature does not verify against the site CA (" + openssl_error() + ")";
  }
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);
  content.assign(data, static_cast<std::size_t>(n));
  return {};
}

}  // namespace teamscan::dds::security
