// Credential bundle check (OpenSSL 3) and Cyclone's security properties; see credentials.hpp.
#include "dds/security/credentials.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>
#include <openssl/x509v3.h>

#include "common/capacities.hpp"
#include "dds/security/openssl_util.hpp"

namespace teamscan::dds::security {

std::string CredentialCheck::summary() const {
  std::string s;
  for (const std::string& p : problems) {
    if (!s.empty()) s += "; ";
    s += p;
  }
  return s;
}

std::string robot_identity(std::uint32_t robot_id) { return "robot" + std::to_string(robot_id); }

std::uint32_t robot_id_of_identity(const std::string& name) {
  if (name.size() < 6 || name.size() > 7 || name.compare(0, 5, "robot") != 0) return 0;
  std::uint32_t id = 0;
  for (std::size_t i = 5; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return 0;
    id = id * 10 + static_cast<std::uint32_t>(name[i] - '0');
  }
  if (name[5] == '0' || id < 1 || id > kMaxRobots) return 0;
  return id;
}

namespace {

std::string path_in(const std::string& dir, const char* file) { return (std::filesystem::path{dir} / file).string(); }

// Tokens of a DN the way Cyclone's access control compares them (split on , / |; order-free).
std::vector<std::string> dn_tokens(const std::string& dn) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : dn) {
    if (c == ',' || c == '/' || c == '|') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  std::sort(out.begin(), out.end());
  return out;
}

// Text between <tag> and </tag> starting at `from`; npos-safe.
std::string xml_text(const std::string& xml, const std::string& tag, std::size_t from, std::size_t to) {
  const std::string open = "<" + tag + ">";
  const std::string close = "</" + tag + ">";
  const std::size_t a = xml.find(open, from);
  if (a == std::string::npos || a >= to) return {};
  const std::size_t b = xml.find(close, a);
  if (b == std::string::npos || b > to) return {};
  return xml.substr(a + open.size(), b - a - open.size());
}

// "2027-12-31T23:59:59" (UTC) -> Unix seconds; -1 if malformed.
std::int64_t parse_xml_time(const std::string& s) {
  std::tm tm{};
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, se = 0;
  if (std::sscanf(s.c_str(), "%d-%d-%dT%d:%d:%d", &y, &mo, &d, &h, &mi, &se) != 6) return -1;
  tm.tm_year = y - 1900; tm.tm_mon = mo - 1; tm.tm_mday = d; tm.tm_hour = h; tm.tm_min = mi; tm.tm_sec = se;
  return static_cast<std::int64_t>(timegm(&tm));
}

}  // namespace

CredentialCheck check_credentials(const std::string& dir, std::int64_t now_s) {
  CredentialCheck out;
  auto problem = [&](const std::string& s) { out.problems.push_back(s); };
  const std::string ca_path = path_in(dir, kCaCertFile);
  const std::string cert_path = path_in(dir, kCertFile);
  const std::string key_path = path_in(dir, kKeyFile);

  X509Ptr ca = read_cert(ca_path);
  if (!ca) problem(ca_path + ": missing or not a PEM certificate");
  X509Ptr cert = read_cert(cert_path);
  if (!cert) problem(cert_path + ": missing or not a PEM certificate");
  EvpKeyPtr key = read_private_key(key_path);
  if (!key) problem(key_path + ": missing, unreadable, not a PEM private key or protected by a password");

  struct stat st{};
  if (::stat(key_path.c_str(), &st) == 0 && (st.st_mode & 077) != 0) {
    char mode[16];
    std::snprintf(mode, sizeof mode, "%03o", static_cast<unsigned>(st.st_mode & 0777));
    problem(key_path + ": mode " + mode + " lets group or others read the private key (chmod 600)");
  }

  X509CrlPtr crl;
  const std::string crl_path = path_in(dir, kCrlFile);
  std::error_code ec;
  if (std::filesystem::exists(crl_path, ec)) {
    crl = read_crl(crl_path);
    if (!crl) problem(crl_path + ": not a PEM certificate revocation list");
  }

  if (ca) {
    if (X509_check_issued(ca.get(), ca.get()) != X509_V_OK) problem(ca_path + ": not a self-signed CA certificate");
    const std::string kt = key_type_problem(X509_get0_pubkey(ca.get()));
    if (!kt.empty()) problem(ca_path + ": " + kt);
    if (crl && X509_CRL_verify(crl.get(), X509_get0_pubkey(ca.get())) != 1)
      problem(crl_path + ": not signed by the CA in " + kCaCertFile);
  }
  if (cert) {
    out.subject = subject_rfc2253(cert.get());
    out.identity = common_name(cert.get());
    out.not_after_s = asn1_time_to_unix(X509_get0_notAfter(cert.get()));
    const std::string kt = key_type_problem(X509_get0_pubkey(cert.get()));
    if (!kt.empty()) problem(cert_path + ": " + kt);
    if (ca) {
      const std::string v = verify_cert(cert.get(), ca.get(), crl.get(), now_s);
      if (!v.empty()) problem(cert_path + ": " + v + " (subject " + out.subject + ")");
    }
    if (key && X509_check_private_key(cert.get(), key.get()) != 1) problem(key_path + ": does not match " + cert_path);
  }

  if (ca) {
    std::string governance_xml;
    const std::string gov_path = path_in(dir, kGovernanceFile);
    const std::string g = verify_smime_file(gov_path, ca.get(), now_s, governance_xml);
    if (!g.empty()) problem(gov_path + ": " + g);

    std::string permissions_xml;
    const std::string perm_path = path_in(dir, kPermissionsFile);
    const std::string p = verify_smime_file(perm_path, ca.get(), now_s, permissions_xml);
    if (!p.empty()) {
      problem(perm_path + ": " + p);
    } else if (cert) {
      // The grant whose subject_name is this certificate's subject (Cyclone compares the DN's tokens).
      const std::vector<std::string> mine = dn_tokens(out.subject);
      bool found = false;
      for (std::size_t at = permissions_xml.find("<grant"); at != std::string::npos;
           at = permissions_xml.find("<grant", at + 1)) {
        const std::size_t end = permissions_xml.find("</grant>", at);
        if (end == std::string::npos) break;
        if (dn_tokens(xml_text(permissions_xml, "subject_name", at, end)) != mine) continue;
        found = true;
        const std::int64_t nb = parse_xml_time(xml_text(permissions_xml, "not_before", at, end));
        const std::int64_t na = parse_xml_time(xml_text(permissions_xml, "not_after", at, end));
        out.permissions_not_after_s = na;
        if (nb < 0 || na < 0) problem(perm_path + ": the grant's validity is malformed");
        else if (now_s < nb) problem(perm_path + ": the grant for " + out.subject + " is not valid yet");
        else if (now_s > na) problem(perm_path + ": the grant for " + out.subject + " has expired");
        break;
      }
      if (!found) problem(perm_path + ": no grant for " + out.subject + " (the permissions are another participant's)");
    }
  }
  return out;
}

CredentialCheck check_credentials_for(const std::string& dir, const std::string& expected_identity, std::int64_t now_s) {
  CredentialCheck c = check_credentials(dir, now_s);
  if (!c.identity.empty() && c.identity != expected_identity)
    c.problems.push_back(path_in(dir, kCertFile) + ": the identity of " + c.identity + ", not of " + expected_identity);
  return c;
}

void add_security_properties(dds_qos_t* qos, const std::string& dir) {
  std::error_code ec;
  std::filesystem::path abs = std::filesystem::absolute(dir, ec);
  if (ec) abs = dir;
  auto file = [&](const char* name) { return "file:" + (abs / name).string(); };
  dds_qset_prop(qos, "dds.sec.auth.library.path", "dds_security_auth");
  dds_qset_prop(qos, "dds.sec.auth.library.init", "init_authentication");
  dds_qset_prop(qos, "dds.sec.auth.library.finalize", "finalize_authentication");
  dds_qset_prop(qos, "dds.sec.access.library.path", "dds_security_ac");
  dds_qset_prop(qos, "dds.sec.access.library.init", "init_access_control");
  dds_qset_prop(qos, "dds.sec.access.library.finalize", "finalize_access_control");
  dds_qset_prop(qos, "dds.sec.crypto.library.path", "dds_security_crypto");
  dds_qset_prop(qos, "dds.sec.crypto.library.init", "init_crypto");
  dds_qset_prop(qos, "dds.sec.crypto.library.finalize", "finalize_crypto");
  dds_qset_prop(qos, "dds.sec.auth.identity_ca", file(kCaCertFile).c_str());
  dds_qset_prop(qos, "dds.sec.auth.identity_certificate", file(kCertFile).c_str());
  dds_qset_prop(qos, "dds.sec.auth.private_key", file(kKeyFile).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions_ca", file(kCaCertFile).c_str());
  dds_qset_prop(qos, "dds.sec.access.governance", file(kGovernanceFile).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions", file(kPermissionsFile).c_str());
  if (std::filesystem::exists(abs / kCrlFile, ec)) dds_qset_prop(qos, "org.eclipse.cyclonedds.sec.auth.crl", file(kCrlFile).c_str());
}

}  // namespace teamscan::dds::security
