// The site PKI of a teamscan installation (`teamscan pki`): a site CA, one identity per robot and for the
// ground station, the signed governance and each participant's signed permissions, revocation (a CRL,
// which Cyclone 0.10.2's authentication plugin honours), and a check that says what is missing, expired
// or does not match. OpenSSL 3's library does the keys, certificates, CRL and S/MIME signatures: it can
// back-date and post-date validity (the command-line `openssl x509` cannot, DDS_SECURITY.md 8.1), and the
// private keys are created with mode 0600 from the start, never briefly world-readable.
//
// Layout of a site folder:
//   ca/ca_key.pem (0600, never leaves this folder), ca/ca_cert.pem, ca/crl.pem, ca/governance.p7s, ca/site.conf
//   <name>/   one credential bundle per participant (dds/security/credentials.hpp): install it as
//             /etc/teamscan/pki/<name>/ on that host; name is robot1..robot32 or station
//   revoked/<name>/cert.pem   the record of a revoked identity (its key is deleted)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "dds/security/openssl_util.hpp"

namespace teamscan::pki {

struct SiteOptions {
  std::uint32_t robots = 2;                  // robot1..robotN
  std::uint32_t domain_min = 0;              // DDS domains the governance and permissions cover
  std::uint32_t domain_max = 0;
  std::string organization = "TeamScan";     // O= of every DN
  std::int64_t now_s = 0;                    // issue time (Unix seconds)
  std::int64_t ca_days = 3650;
  std::int64_t identity_days = 365;
};

// Each returns an error that names what failed (a file, an identity, OpenSSL's reason).
[[nodiscard]] Status create_site(const std::string& dir, const SiteOptions& options);
// A new (or renewed) identity `name` (robotN or station) valid from not_before_s to not_after_s; its
// permissions grant has the same validity.
[[nodiscard]] Status issue_identity(const std::string& dir, const std::string& name, std::int64_t not_before_s,
                                    std::int64_t not_after_s);
// Adds name's certificate to the site CRL, copies the new CRL into every remaining bundle, and moves the
// bundle to revoked/<name>/ without its key. Install the new crl.pem on every host, then restart.
[[nodiscard]] Status revoke_identity(const std::string& dir, const std::string& name, std::int64_t now_s);

struct SiteReport {
  std::vector<std::string> lines;            // one per participant and for the CA
  std::uint32_t problems = 0;                // missing, expired, mismatched, badly protected
  std::uint32_t warnings = 0;                // expiring within 30 days
};
[[nodiscard]] SiteReport check_site(const std::string& dir, std::int64_t now_s);

// The documents (pure text).
[[nodiscard]] std::string governance_xml(std::uint32_t domain_min, std::uint32_t domain_max);
[[nodiscard]] std::string permissions_xml(const std::string& name, const std::string& subject, std::uint32_t domain_min,
                                          std::uint32_t domain_max, std::int64_t not_before_s, std::int64_t not_after_s);

// The pieces, for tools and tests that build credentials by hand (another CA, an expired identity).
struct CertAuthority {
  dds::security::EvpKeyPtr key;
  dds::security::X509Ptr cert;
};
[[nodiscard]] dds::security::EvpKeyPtr make_key();  // EC P-256
[[nodiscard]] CertAuthority make_ca(const std::string& organization, std::int64_t not_before_s, std::int64_t not_after_s);
[[nodiscard]] dds::security::X509Ptr issue_cert(const CertAuthority& ca, EVP_PKEY* key, const std::string& cn,
                                           const std::string& organization, std::int64_t not_before_s,
                                           std::int64_t not_after_s);
[[nodiscard]] std::string sign_smime(const CertAuthority& ca, const std::string& text);  // "" on failure
[[nodiscard]] std::string crl_pem(const CertAuthority& ca, const std::vector<X509*>& revoked, std::int64_t now_s);
// Writes a private key with mode 0600 (created so, and fchmod'ed if it existed).
[[nodiscard]] Status write_private_key(const std::string& path, EVP_PKEY* key);
[[nodiscard]] Status write_text(const std::string& path, const std::string& text);
[[nodiscard]] std::string cert_pem(X509* cert);

}  // namespace teamscan::pki
