// Site PKI with OpenSSL 3; see site_pki.hpp.
#include "tools/pki/site_pki.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <openssl/bn.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/x509v3.h>

#include "common/capacities.hpp"
#include "common/error_message.hpp"
#include "dds/security/credentials.hpp"

namespace teamscan::pki {

namespace fs = std::filesystem;
using dds::security::BioPtr;
using dds::security::EvpKeyPtr;
using dds::security::X509Ptr;

namespace {

constexpr std::int64_t kDay = 86400;

std::string iso_utc(std::int64_t t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

std::string domains_xml(std::uint32_t lo, std::uint32_t hi) {
  if (lo == hi) return "<domains><id>" + std::to_string(lo) + "</id></domains>";
  return "<domains><id_range><min>" + std::to_string(lo) + "</min><max>" + std::to_string(hi) + "</max></id_range></domains>";
}

std::string bio_string(BIO* bio) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  return std::string(data, static_cast<std::size_t>(n));
}

bool add_ext(X509* cert, X509* issuer, int nid, const char* value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, issuer, cert, nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
  if (ext == nullptr) return false;
  const bool ok = X509_add_ext(cert, ext, -1) == 1;
  X509_EXTENSION_free(ext);
  return ok;
}

X509Ptr new_cert(EVP_PKEY* key, const std::string& cn, const std::string& organization, std::int64_t not_before_s,
                 std::int64_t not_after_s) {
  X509Ptr cert{X509_new()};
  X509_set_version(cert.get(), 2);
  unsigned char serial[8];
  RAND_bytes(serial, sizeof serial);
  serial[0] &= 0x7f;  // positive
  BIGNUM* bn = BN_bin2bn(serial, sizeof serial, nullptr);
  BN_to_ASN1_INTEGER(bn, X509_get_serialNumber(cert.get()));
  BN_free(bn);
  X509_NAME* name = X509_get_subject_name(cert.get());
  X509_NAME_add_entry_by_txt(name, "O", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(organization.c_str()), -1, -1, 0);
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(cn.c_str()), -1, -1, 0);
  ASN1_TIME_set(X509_getm_notBefore(cert.get()), static_cast<time_t>(not_before_s));
  ASN1_TIME_set(X509_getm_notAfter(cert.get()), static_cast<time_t>(not_after_s));
  X509_set_pubkey(cert.get(), key);
  return cert;
}

struct Site {
  CertAuthority ca;
  std::uint32_t robots = 0;
  std::uint32_t domain_min = 0;
  std::uint32_t domain_max = 0;
  std::string organization;
};

std::string ca_dir(const std::string& dir) { return (fs::path{dir} / "ca").string(); }

Status load_site(const std::string& dir, Site& site) {
  const fs::path ca = ca_dir(dir);
  site.ca.cert = dds::security::read_cert((ca / "ca_cert.pem").string());
  site.ca.key = dds::security::read_private_key((ca / "ca_key.pem").string());
  if (!site.ca.cert || !site.ca.key) return make_error(dir + "/ca: no site CA here (teamscan pki init " + dir + ")");
  std::ifstream in(ca / "site.conf");
  if (!in) return make_error((ca / "site.conf").string() + ": missing");
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string k = line.substr(0, eq);
    const std::string v = line.substr(eq + 1);
    if (k == "robots") site.robots = static_cast<std::uint32_t>(std::stoul(v));
    else if (k == "domain_min") site.domain_min = static_cast<std::uint32_t>(std::stoul(v));
    else if (k == "domain_max") site.domain_max = static_cast<std::uint32_t>(std::stoul(v));
    else if (k == "organization") site.organization = v;
  }
  if (site.organization.empty()) return make_error((ca / "site.conf").string() + ": no organization");
  return ok_status();
}

bool valid_name(const std::string& name) {
  return name == dds::security::kStationIdentity || dds::security::robot_id_of_identity(name) != 0;
}

Status copy_site_file(const std::string& dir, const char* file, const fs::path& bundle) {
  std::error_code ec;
  fs::copy_file(fs::path{ca_dir(dir)} / file, bundle / file, fs::copy_options::overwrite_existing, ec);
  if (ec) return make_error((bundle / file).string() + ": " + ec.message());
  return ok_status();
}

// The CRL of every certificate under revoked/.
Status write_site_crl(const std::string& dir, const Site& site, std::int64_t now_s) {
  std::vector<X509Ptr> certs;
  const fs::path revoked = fs::path{dir} / "revoked";
  if (fs::exists(revoked)) {
    for (const auto& e : fs::directory_iterator(revoked)) {
      X509Ptr c = dds::security::read_cert((e.path() / dds::security::kCertFile).string());
      if (c) certs.push_back(std::move(c));
    }
  }
  std::vector<X509*> raw;
  for (const auto& c : certs) raw.push_back(c.get());
  const std::string pem = crl_pem(site.ca, raw, now_s);
  if (pem.empty()) return make_error("cannot sign the CRL: " + dds::security::openssl_error());
  return write_text((fs::path{ca_dir(dir)} / dds::security::kCrlFile).string(), pem);
}

}  // namespace

std::string governance_xml(std::uint32_t domain_min, std::uint32_t domain_max) {
  // Every teamscan topic and the ROS 2 wire topics the station publishes: discovery, liveliness, metadata
  // and data signed and encrypted (AES-GCM), read and write access controlled; RTPS messages signed too.
  std::string rules;
  for (const char* expr : {"teamscan/*", "rt/*"}) {
    rules += std::string{"    <topic_rule>\n      <topic_expression>"} + expr + "</topic_expression>\n"
             "      <enable_discovery_protection>true</enable_discovery_protection>\n"
             "      <enable_liveliness_protection>true</enable_liveliness_protection>\n"
             "      <enable_read_access_control>true</enable_read_access_control>\n"
             "      <enable_write_access_control>true</enable_write_access_control>\n"
             "      <metadata_protection_kind>ENCRYPT</metadata_protection_kind>\n"
             "      <data_protection_kind>ENCRYPT</data_protection_kind>\n"
             "    </topic_rule>\n";
  }
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<dds>\n<domain_access_rules>\n <domain_rule>\n  " +
         domains_xml(domain_min, domain_max) +
         "\n  <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
         "  <enable_join_access_control>true</enable_join_access_control>\n"
         "  <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
         "  <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
         "  <rtps_protection_kind>SIGN</rtps_protection_kind>\n"
         "  <topic_access_rules>\n" + rules + "  </topic_access_rules>\n </domain_rule>\n</domain_access_rules>\n</dds>\n";
}

std::string permissions_xml(const std::string& name, const std::string& subject, std::uint32_t domain_min,
                            std::uint32_t domain_max, std::int64_t not_before_s, std::int64_t not_after_s) {
  std::string body;
  if (name == dds::security::kStationIdentity) {
    // The station publishes the team state, what it stored, the map and the ROS 2 view (default partition)
    // and reads every robot's pose, scan, back-filled scan and pose and status in the robots' partitions.
    body = "    <publish><topics><topic>teamscan/team</topic><topic>teamscan/stored</topic><topic>teamscan/map</topic>"
           "<topic>rt/*</topic></topics></publish>\n"
           "    <subscribe>\n      <topics><topic>teamscan/scan</topic><topic>teamscan/pose</topic><topic>teamscan/status</topic>"
           "<topic>teamscan/backfill</topic><topic>teamscan/backfill_pose</topic></topics>\n"
           "      <partitions><partition>robot*</partition></partitions>\n    </subscribe>\n";
  } else {
    // Robot N publishes its pose, scan, back-filled scans and poses and status only in its own partition robotN and
    // reads the team state and what the station stored.
    body = "    <publish>\n      <topics><topic>teamscan/scan</topic><topic>teamscan/pose</topic><topic>teamscan/status</topic>"
           "<topic>teamscan/backfill</topic><topic>teamscan/backfill_pose</topic></topics>\n"
           "      <partitions><partition>" + name + "</partition></partitions>\n    </publish>\n"
           "    <subscribe><topics><topic>teamscan/team</topic><topic>teamscan/stored</topic></topics></subscribe>\n";
  }
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<dds>\n<permissions>\n <grant name=\"" + name + "\">\n  <subject_name>" +
         subject + "</subject_name>\n  <validity><not_before>" + iso_utc(not_before_s) + "</not_before><not_after>" +
         iso_utc(not_after_s) + "</not_after></validity>\n  <allow_rule>\n    " + domains_xml(domain_min, domain_max) + "\n" +
         body + "  </allow_rule>\n  <default>DENY</default>\n </grant>\n</permissions>\n</dds>\n";
}

EvpKeyPtr make_key() { return EvpKeyPtr{EVP_EC_gen("P-256")}; }

CertAuthority make_ca(const std::string& organization, std::int64_t not_before_s, std::int64_t not_after_s) {
  CertAuthority ca;
  ca.key = make_key();
  if (!ca.key) return ca;
  ca.cert = new_cert(ca.key.get(), organization + " Site CA", organization, not_before_s, not_after_s);
  X509_set_issuer_name(ca.cert.get(), X509_get_subject_name(ca.cert.get()));
  add_ext(ca.cert.get(), ca.cert.get(), NID_basic_constraints, "critical,CA:TRUE");
  add_ext(ca.cert.get(), ca.cert.get(), NID_key_usage, "critical,keyCertSign,cRLSign,digitalSignature");
  add_ext(ca.cert.get(), ca.cert.get(), NID_subject_key_identifier, "hash");
  if (X509_sign(ca.cert.get(), ca.key.get(), EVP_sha256()) <= 0) ca.cert.reset();
  return ca;
}

X509Ptr issue_cert(const CertAuthority& ca, EVP_PKEY* key, const std::string& cn, const std::string& organization,
                   std::int64_t not_before_s, std::int64_t not_after_s) {
  X509Ptr cert = new_cert(key, cn, organization, not_before_s, not_after_s);
  X509_set_issuer_name(cert.get(), X509_get_subject_name(ca.cert.get()));
  add_ext(cert.get(), ca.cert.get(), NID_basic_constraints, "critical,CA:FALSE");
  add_ext(cert.get(), ca.cert.get(), NID_key_usage, "critical,digitalSignature");
  if (X509_sign(cert.get(), ca.key.get(), EVP_sha256()) <= 0) return nullptr;
  return cert;
}

std::string sign_smime(const CertAuthority& ca, const std::string& text) {
  // As `openssl smime -sign -text`: detached multipart/signed with a text/plain part.
  const int flags = PKCS7_DETACHED | PKCS7_TEXT | PKCS7_STREAM;
  BioPtr in{BIO_new_mem_buf(text.data(), static_cast<int>(text.size()))};
  dds::security::Pkcs7Ptr p7{PKCS7_sign(ca.cert.get(), ca.key.get(), nullptr, in.get(), flags)};
  if (!p7) return {};
  BioPtr data{BIO_new_mem_buf(text.data(), static_cast<int>(text.size()))};
  BioPtr out{BIO_new(BIO_s_mem())};
  if (SMIME_write_PKCS7(out.get(), p7.get(), data.get(), flags) != 1) return {};
  return bio_string(out.get());
}

std::string crl_pem(const CertAuthority& ca, const std::vector<X509*>& revoked, std::int64_t now_s) {
  dds::security::X509CrlPtr crl{X509_CRL_new()};
  X509_CRL_set_version(crl.get(), 1);
  X509_CRL_set_issuer_name(crl.get(), X509_get_subject_name(ca.cert.get()));
  ASN1_TIME* now = ASN1_TIME_set(nullptr, static_cast<time_t>(now_s));
  X509_CRL_set1_lastUpdate(crl.get(), now);
  // Valid as long as the CA: an outdated CRL would make OpenSSL refuse every certificate of the site.
  X509_CRL_set1_nextUpdate(crl.get(), X509_get0_notAfter(ca.cert.get()));
  for (X509* c : revoked) {
    X509_REVOKED* r = X509_REVOKED_new();
    X509_REVOKED_set_serialNumber(r, X509_get_serialNumber(c));
    X509_REVOKED_set_revocationDate(r, now);
    X509_CRL_add0_revoked(crl.get(), r);
  }
  ASN1_TIME_free(now);
  X509_CRL_sort(crl.get());
  if (X509_CRL_sign(crl.get(), ca.key.get(), EVP_sha256()) <= 0) return {};
  BioPtr out{BIO_new(BIO_s_mem())};
  PEM_write_bio_X509_CRL(out.get(), crl.get());
  return bio_string(out.get());
}

Status write_private_key(const std::string& path, EVP_PKEY* key) {
  BioPtr mem{BIO_new(BIO_s_mem())};
  if (PEM_write_bio_PrivateKey(mem.get(), key, nullptr, nullptr, 0, nullptr, nullptr) != 1)
    return make_error(path + ": " + dds::security::openssl_error());
  const std::string pem = bio_string(mem.get());
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) return make_error(path + ": " + std::strerror(errno));
  bool ok = ::fchmod(fd, 0600) == 0;
  ok = ok && ::write(fd, pem.data(), pem.size()) == static_cast<ssize_t>(pem.size());
  ok = (::close(fd) == 0) && ok;
  if (!ok) return make_error(path + ": cannot write the private key");
  return ok_status();
}

Status write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) return make_error(path + ": cannot write");
  return ok_status();
}

std::string cert_pem(X509* cert) {
  BioPtr out{BIO_new(BIO_s_mem())};
  PEM_write_bio_X509(out.get(), cert);
  return bio_string(out.get());
}

Status create_site(const std::string& dir, const SiteOptions& o) {
  if (o.robots < 1 || o.robots > kMaxRobots) return make_error("robots must be 1.." + std::to_string(kMaxRobots));
  if (o.domain_min > o.domain_max || o.domain_max > 232) return make_error("domains must be a range within 0..232");
  if (o.organization.empty() || o.organization.find_first_of(",/|=") != std::string::npos)
    return make_error("the organization must be non-empty and free of , / | = (DN separators, DDS_SECURITY.md 8.3)");
  const fs::path ca = ca_dir(dir);
  if (fs::exists(ca / "ca_key.pem")) return make_error(ca.string() + ": a site CA exists already (issue or revoke identities instead)");
  std::error_code ec;
  fs::create_directories(ca, ec);
  if (ec) return make_error(ca.string() + ": " + ec.message());
  fs::permissions(ca, fs::perms::owner_all, ec);
  Site site;
  site.robots = o.robots;
  site.domain_min = o.domain_min;
  site.domain_max = o.domain_max;
  site.organization = o.organization;
  // Back-date by a minute: a host whose clock is a little behind accepts the certificates at once.
  site.ca = make_ca(o.organization, o.now_s - 60, o.now_s + o.ca_days * kDay);
  if (!site.ca.cert) return make_error("cannot create the site CA: " + dds::security::openssl_error());
  Status e = write_private_key((ca / "ca_key.pem").string(), site.ca.key.get());
  if (e.ok()) e = write_text((ca / "ca_cert.pem").string(), cert_pem(site.ca.cert.get()));
  if (e.ok())
    e = write_text((ca / "site.conf").string(), "robots=" + std::to_string(o.robots) + "\ndomain_min=" +
                                                    std::to_string(o.domain_min) + "\ndomain_max=" +
                                                    std::to_string(o.domain_max) + "\norganization=" + o.organization + "\n");
  if (!e.ok()) return e;
  const std::string gov = sign_smime(site.ca, governance_xml(o.domain_min, o.domain_max));
  if (gov.empty()) return make_error("cannot sign the governance: " + dds::security::openssl_error());
  e = write_text((ca / dds::security::kGovernanceFile).string(), gov);
  if (e.ok()) e = write_site_crl(dir, site, o.now_s);
  if (!e.ok()) return e;
  std::vector<std::string> names{dds::security::kStationIdentity};
  for (std::uint32_t n = 1; n <= o.robots; ++n) names.push_back(dds::security::robot_identity(n));
  for (const std::string& n : names) {
    e = issue_identity(dir, n, o.now_s - 60, o.now_s + o.identity_days * kDay);
    if (!e.ok()) return e;
  }
  return ok_status();
}

Status issue_identity(const std::string& dir, const std::string& name, std::int64_t not_before_s,
                           std::int64_t not_after_s) {
  if (!valid_name(name)) return make_error("'" + name + "' is not an identity name (robot1..robot32 or station)");
  Site site;
  Status e = load_site(dir, site);
  if (!e.ok()) return e;
  const fs::path bundle = fs::path{dir} / name;
  std::error_code ec;
  fs::create_directories(bundle, ec);
  if (ec) return make_error(bundle.string() + ": " + ec.message());
  fs::permissions(bundle, fs::perms::owner_all, ec);
  EvpKeyPtr key = make_key();
  if (!key) return make_error("cannot create a key: " + dds::security::openssl_error());
  X509Ptr cert = issue_cert(site.ca, key.get(), name, site.organization, not_before_s, not_after_s);
  if (!cert) return make_error("cannot sign the certificate of " + name + ": " + dds::security::openssl_error());
  const std::string perms = sign_smime(site.ca, permissions_xml(name, dds::security::subject_rfc2253(cert.get()), site.domain_min,
                                                                 site.domain_max, not_before_s, not_after_s));
  if (perms.empty()) return make_error("cannot sign the permissions of " + name + ": " + dds::security::openssl_error());
  e = write_private_key((bundle / dds::security::kKeyFile).string(), key.get());
  if (e.ok()) e = write_text((bundle / dds::security::kCertFile).string(), cert_pem(cert.get()));
  if (e.ok()) e = write_text((bundle / dds::security::kPermissionsFile).string(), perms);
  for (const char* f : {dds::security::kCaCertFile, dds::security::kGovernanceFile, dds::security::kCrlFile})
    if (e.ok()) e = copy_site_file(dir, f, bundle);
  return e;
}

Status revoke_identity(const std::string& dir, const std::string& name, std::int64_t now_s) {
  if (!valid_name(name)) return make_error("'" + name + "' is not an identity name (robot1..robot32 or station)");
  Site site;
  Status e = load_site(dir, site);
  if (!e.ok()) return e;
  const fs::path bundle = fs::path{dir} / name;
  if (!fs::exists(bundle / dds::security::kCertFile)) return make_error(bundle.string() + ": no such identity");
  const fs::path record = fs::path{dir} / "revoked" / name;
  std::error_code ec;
  fs::remove_all(record, ec);
  fs::create_directories(record, ec);
  fs::copy_file(bundle / dds::security::kCertFile, record / dds::security::kCertFile, fs::copy_options::overwrite_existing, ec);
  if (ec) return make_error(record.string() + ": " + ec.message());
  fs::remove_all(bundle, ec);
  if (ec) return make_error(bundle.string() + ": " + ec.message());
  e = write_site_crl(dir, site, now_s);
  if (!e.ok()) return e;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_directory() || !valid_name(entry.path().filename().string())) continue;
    e = copy_site_file(dir, dds::security::kCrlFile, entry.path());
    if (!e.ok()) return e;
  }
  return ok_status();
}

SiteReport check_site(const std::string& dir, std::int64_t now_s) {
  SiteReport r;
  auto problem = [&](const std::string& s) { r.lines.push_back(s); ++r.problems; };
  Site site;
  const Status e = load_site(dir, site);
  if (!e.ok()) {
    problem(e.error().what);
    return r;
  }
  const fs::path ca = ca_dir(dir);
  if (X509_check_private_key(site.ca.cert.get(), site.ca.key.get()) != 1) problem("ca: ca_key.pem does not match ca_cert.pem");
  struct stat st{};
  if (::stat((ca / "ca_key.pem").c_str(), &st) == 0 && (st.st_mode & 077) != 0) problem("ca: ca_key.pem is readable by group or others (chmod 600)");
  const std::int64_t ca_until = dds::security::asn1_time_to_unix(X509_get0_notAfter(site.ca.cert.get()));
  if (ca_until < now_s) problem("ca: the site CA expired on " + dds::security::unix_to_utc(ca_until));
  else r.lines.push_back("ca: ok, valid until " + dds::security::unix_to_utc(ca_until));

  std::string site_files[3];
  const char* shared[3] = {dds::security::kCaCertFile, dds::security::kGovernanceFile, dds::security::kCrlFile};
  for (int i = 0; i < 3; ++i) (void)dds::security::read_file((ca / shared[i]).string(), site_files[i]);

  std::vector<std::string> expected{dds::security::kStationIdentity};
  for (std::uint32_t n = 1; n <= site.robots; ++n) expected.push_back(dds::security::robot_identity(n));
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string n = entry.path().filename().string();
    if (entry.is_directory() && valid_name(n) && std::find(expected.begin(), expected.end(), n) == expected.end())
      expected.push_back(n);
  }
  std::sort(expected.begin(), expected.end());
  for (const std::string& n : expected) {
    const fs::path bundle = fs::path{dir} / n;
    if (fs::exists(fs::path{dir} / "revoked" / n)) {
      if (fs::exists(bundle)) problem(n + ": revoked, but its bundle is still here");
      else r.lines.push_back(n + ": revoked");
      continue;
    }
    if (!fs::exists(bundle)) {
      problem(n + ": missing (teamscan pki issue " + dir + " " + n + ")");
      continue;
    }
    const dds::security::CredentialCheck c = dds::security::check_credentials(bundle.string(), now_s);
    std::vector<std::string> issues = c.problems;
    if (!c.identity.empty() && c.identity != n) issues.push_back("cert.pem is the identity of " + c.identity + ", not " + n);
    for (int i = 0; i < 3; ++i) {
      std::string mine;
      if (dds::security::read_file((bundle / shared[i]).string(), mine) && mine != site_files[i])
        issues.push_back(std::string{shared[i]} + " differs from the site's ca/" + shared[i] +
                         (i == 2 ? " (install the current CRL after a revocation)" : ""));
    }
    if (!issues.empty()) {
      std::string line = n + ":";
      for (const std::string& s : issues) line += "\n    " + s;
      problem(line);
      continue;
    }
    const std::int64_t until = std::min(c.not_after_s, c.permissions_not_after_s);
    if (until - now_s < 30 * kDay) {
      ++r.warnings;
      r.lines.push_back(n + ": ok, but expires on " + dds::security::unix_to_utc(until) + " (renew: teamscan pki issue " + dir + " " + n + ")");
    } else {
      r.lines.push_back(n + ": ok, valid until " + dds::security::unix_to_utc(until));
    }
  }
  return r;
}

}  // namespace teamscan::pki
