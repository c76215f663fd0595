// Small OpenSSL 3 helpers shared by the credential check (dds/security) and the site PKI tool
// (tools/pki): owning pointers, PEM reading, certificate and S/MIME verification at a given time.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <openssl/evp.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>

namespace teamscan::dds::security {

struct X509Free { void operator()(X509* p) const { X509_free(p); } };
struct EvpKeyFree { void operator()(EVP_PKEY* p) const { EVP_PKEY_free(p); } };
struct X509CrlFree { void operator()(X509_CRL* p) const { X509_CRL_free(p); } };
struct BioFree { void operator()(BIO* p) const { BIO_free_all(p); } };
struct Pkcs7Free { void operator()(PKCS7* p) const { PKCS7_free(p); } };
using X509Ptr = std::unique_ptr<X509, X509Free>;
using EvpKeyPtr = std::unique_ptr<EVP_PKEY, EvpKeyFree>;
using X509CrlPtr = std::unique_ptr<X509_CRL, X509CrlFree>;
using BioPtr = std::unique_ptr<BIO, BioFree>;
using Pkcs7Ptr = std::unique_ptr<PKCS7, Pkcs7Free>;

// The whole file, or false if it cannot be read.
bool read_file(const std::string& path, std::string& out);
// PEM readers; null if the file is missing or not that kind of PEM. Never prompts for a password.
X509Ptr read_cert(const std::string& path);
EvpKeyPtr read_private_key(const std::string& path);
X509CrlPtr read_crl(const std::string& path);

// The first queued OpenSSL error as text (and clears the queue); "unknown OpenSSL error" if none.
std::string openssl_error();

// Empty if Cyclone 0.10.2's plugins accept this key (EC P-256 or RSA-2048), else why not.
std::string key_type_problem(EVP_PKEY* key);
std::string subject_rfc2253(X509* cert);   // "CN=robot1,O=TeamScan"
std::string common_name(X509* cert);       // "robot1"
std::int64_t asn1_time_to_unix(const ASN1_TIME* t);
std::string unix_to_utc(std::int64_t t);   // "2027-12-31 23:59:59 UTC"

// Empty if `cert` is signed by `ca`, valid at now_s and (with a CRL) not revoked; else the reason.
std::string verify_cert(X509* cert, X509* ca, X509_CRL* crl, std::int64_t now_s);
// Verifies an S/MIME (detached, text) document signed by `ca` at now_s; on success `content` is the
// signed text without its MIME header. Empty on success, else the reason.
std::string verify_smime_file(const std::string& path, X509* ca, std::int64_t now_s, std::string& content);

}  // namespace teamscan::dds::security
