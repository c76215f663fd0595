// `teamscan pki`: the site's DDS Security PKI (tools/pki/site_pki.hpp). init creates the CA, the station's
// and every robot's identity, the signed governance and permissions; issue adds or renews one identity;
// revoke puts one on the CRL; check says what is missing, expired or does not match.
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>

#include "tools/pki/site_pki.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct PkiArgs {
  std::string dir;
  std::string name;
  pki::SiteOptions site;
  std::string domains = "0";
  std::int64_t days = 365;
};

std::int64_t now_s() { return static_cast<std::int64_t>(std::time(nullptr)); }

bool parse_domains(const std::string& s, pki::SiteOptions& o) {
  unsigned lo = 0, hi = 0;
  char dash = 0;
  if (std::sscanf(s.c_str(), "%u%c%u", &lo, &dash, &hi) == 3 && dash == '-') {
  } else if (std::sscanf(s.c_str(), "%u", &lo) == 1) {
    hi = lo;
  } else {
    return false;
  }
  o.domain_min = lo;
  o.domain_max = hi;
  return true;
}

int report(const char* what, const Status& s) {
  if (!s.ok()) {
    std::fprintf(stderr, "teamscan pki %s: %s\n", what, s.error().what);
    return 1;
  }
  return 0;
}

int run_init(PkiArgs& a) {
  if (!parse_domains(a.domains, a.site)) return report("init", Error{"--domains takes N or N-M"}) == 0 ? 0 : 2;  // usage
  a.site.now_s = now_s();
  a.site.identity_days = a.days;
  if (report("init", pki::create_site(a.dir, a.site)) != 0) return 1;
  std::printf("site PKI in %s: CA (ca/, keep ca_key.pem offline), station and robot1..robot%u, domains %u-%u\n"
              "install each participant's folder as /etc/teamscan/pki/<name>/ on its host (docs/security.md)\n",
              a.dir.c_str(), a.site.robots, a.site.domain_min, a.site.domain_max);
  return 0;
}

int run_issue(const PkiArgs& a) {
  const std::int64_t now = now_s();
  if (report("issue", pki::issue_identity(a.dir, a.name, now - 60, now + a.days * 86400)) != 0) return 1;
  std::printf("%s/%s: new identity valid for %lld days\n", a.dir.c_str(), a.name.c_str(), static_cast<long long>(a.days));
  return 0;
}

int run_revoke(const PkiArgs& a) {
  if (report("revoke", pki::revoke_identity(a.dir, a.name, now_s())) != 0) return 1;
  std::printf("%s revoked: install %s/ca/crl.pem as crl.pem on every host and restart the daemons\n", a.name.c_str(),
              a.dir.c_str());
  return 0;
}

int run_check(const PkiArgs& a) {
  const pki::SiteReport r = pki::check_site(a.dir, now_s());
  for (const std::string& l : r.lines) std::printf("%s\n", l.c_str());
  std::printf("%u problem(s), %u warning(s)\n", r.problems, r.warnings);
  return r.problems == 0 ? 0 : 1;
}

const SubcommandRegistration kPki{{"pki", "Site PKI for DDS Security: init, issue, revoke, check", [](CLI::App& app) {
  auto a = std::make_shared<PkiArgs>();
  auto mode = std::make_shared<int>(0);
  app.require_subcommand(1);
  CLI::App* init = app.add_subcommand("init", "Create the site CA, the station's and robot1..N's identities, governance and permissions");
  init->add_option("DIR", a->dir, "Site folder (created)")->required();
  init->add_option("--robots", a->site.robots, "Robots in the team (1..32)")->capture_default_str();
  init->add_option("--domains", a->domains, "DDS domain id, or a range N-M, the governance and permissions cover")->capture_default_str();
  init->add_option("--organization", a->site.organization, "O= of every certificate's name")->capture_default_str();
  init->add_option("--days", a->days, "Validity of the identities in days (the CA: 10 years)")->capture_default_str();
  init->callback([mode] { *mode = 1; });
  CLI::App* issue = app.add_subcommand("issue", "Add or renew one identity (robotN or station)");
  issue->add_option("DIR", a->dir, "Site folder")->required()->check(CLI::ExistingDirectory);
  issue->add_option("NAME", a->name, "robot1..robot32 or station")->required();
  issue->add_option("--days", a->days, "Validity in days")->capture_default_str();
  issue->callback([mode] { *mode = 2; });
  CLI::App* revoke = app.add_subcommand("revoke", "Revoke one identity: CRL entry, bundle removed");
  revoke->add_option("DIR", a->dir, "Site folder")->required()->check(CLI::ExistingDirectory);
  revoke->add_option("NAME", a->name, "robot1..robot32 or station")->required();
  revoke->callback([mode] { *mode = 3; });
  CLI::App* check = app.add_subcommand("check", "Say what is missing, expired or does not match (exit 1 if anything)");
  check->add_option("DIR", a->dir, "Site folder")->required()->check(CLI::ExistingDirectory);
  check->callback([mode] { *mode = 4; });
  return [a, mode] {
    switch (*mode) {
      case 1: return run_init(*a);
      case 2: return run_issue(*a);
      case 3: return run_revoke(*a);
      default: return run_check(*a);
    }
  };
}}};

}  // namespace
}  // namespace teamscan::tool
