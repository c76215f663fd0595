// The DDS Security credentials of one participant, their check before start-up, and the participant QoS
// properties that switch Cyclone's security plugins on (DDS_SECURITY.md 1, 5).
//
// A credential bundle is one folder with fixed file names: what `teamscan pki` writes per participant
// (site/robot3/, site/station/), what is installed at /etc/teamscan/pki/<name>/, and what systemd's
// LoadCredential= hands the daemon in $CREDENTIALS_DIRECTORY. The daemons pass the folder to
// add_security_properties(); nothing else in the process names a credential file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <dds/dds.h>

namespace teamscan::dds::security {

inline constexpr const char* kCaCertFile = "ca_cert.pem";          // the site CA (identity and permissions CA)
inline constexpr const char* kCertFile = "cert.pem";               // this participant's identity certificate
inline constexpr const char* kKeyFile = "key.pem";                 // its private key (mode 0600 or stricter)
inline constexpr const char* kGovernanceFile = "governance.p7s";   // the site's governance, signed by the CA
inline constexpr const char* kPermissionsFile = "permissions.p7s"; // this participant's grant, signed by the CA
inline constexpr const char* kCrlFile = "crl.pem";                 // the site's revocation list, signed by the CA

// What check_credentials found. `problems` is empty when the bundle is usable at `now`.
struct CredentialCheck {
  std::string identity;                // CN of cert.pem ("robot3", "station"); empty if unreadable
  std::string subject;                 // cert.pem's subject, RFC 2253 ("CN=robot3,O=TeamScan")
  std::int64_t not_after_s = 0;        // cert.pem's notAfter (Unix seconds), 0 if unreadable
  std::int64_t permissions_not_after_s = 0;
  std::vector<std::string> problems;   // one clear sentence each, naming the file
  [[nodiscard]] bool ok() const { return problems.empty(); }
  [[nodiscard]] std::string summary() const;  // the problems joined by "; "
};

// Checks the bundle in `dir` as Cyclone's plugins will at time `now_s` (Unix seconds), but says what is
// wrong instead of failing participant creation with -1: every file present and readable; the CA
// self-signed; the certificate signed by the CA, valid at now, not revoked by crl.pem, with a key type
// the 0.10.2 plugins accept (EC P-256 or RSA-2048); the private key matches the certificate and is not
// readable by group or others; governance and permissions signed by the CA; the permissions hold a
// grant for the certificate's subject that is valid at now.
[[nodiscard]] CredentialCheck check_credentials(const std::string& dir, std::int64_t now_s);

// check_credentials, and cert.pem must be `expected_identity`'s ("robot3", "station"): what a daemon
// runs before it creates its participant.
[[nodiscard]] CredentialCheck check_credentials_for(const std::string& dir, const std::string& expected_identity,
                                                    std::int64_t now_s);

// Adds to a participant QoS the security properties naming the bundle's files (absolute paths): the
// participant then authenticates, is access-controlled and encrypts as the signed governance says.
// crl.pem is named only if present.
void add_security_properties(dds_qos_t* qos, const std::string& dir);

// Identity names: "robot<N>" for robot N (1..32), "station" for the ground station. The robot's
// identity name is also the DDS partition its pose, scan and status are published in.
inline constexpr const char* kStationIdentity = "station";
[[nodiscard]] std::string robot_identity(std::uint32_t robot_id);
// The robot id named by "robot<N>" (1..32), or 0 if `name` is not a robot identity.
[[nodiscard]] std::uint32_t robot_id_of_identity(const std::string& name);

}  // namespace teamscan::dds::security
