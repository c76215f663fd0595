// End to end with DDS Security: `teamscan demo --secure` (a throwaway site PKI, every daemon
// authenticated, encrypted, access-controlled) on a shortened lap2 loses nothing and reaches the same
// verdict as without security (e2e_demo_test): every published scan stored without gaps, the live model
// and the session's evaluation agree with offline eval, every process exits 0, and the station ran
// secured and refused no sample.
#include <gtest/gtest.h>

#include "tests/hil/e2e/e2e_support.hpp"

namespace teamscan::e2e {
namespace {

TEST(E2eSecureDemo, Lap2WithDdsSecurityLosesNothingAndAgreesWithOfflineEval) {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/teamscan-e2e-secure-" + std::to_string(::getpid());
  const int rc = run_demo(dir, "--secure --scenario lap2 --duration 12 --bringup 4");
  const std::string log = demo_log(dir);
  const std::string s = read_file(dir + "/summary.json");
  ASSERT_FALSE(s.empty()) << log;
  EXPECT_EQ(rc, 0) << log;
  EXPECT_EQ(json_value(s, "secure"), "true") << s;
  for (int id : {1, 2}) {
    const std::size_t r = robot_entry(s, id);
    ASSERT_NE(r, std::string::npos) << "robot " << id << "\n" << s;
    EXPECT_EQ(json_number(s, "missing", r), 0) << s;
    EXPECT_GE(json_number(s, "seq_last", r), json_number(s, "last_status_published", r)) << s;
    EXPECT_GT(json_number(s, "last_status_published", r), 0) << s;
    EXPECT_GE(json_number(s, "stored", r), 0.95 * json_number(s, "lms_sent", r)) << s;
    const std::string onboard = read_file(dir + "/logs/onboard-robot" + std::to_string(id) + ".log");
    EXPECT_NE(onboard.find("DDS Security: identity CN=robot" + std::to_string(id)), std::string::npos) << onboard;
  }
  const std::size_t sm = s.find("\"station_model\":");
  ASSERT_NE(sm, std::string::npos) << s;
  EXPECT_EQ(json_value(s, "within_tolerance", sm), "true") << log;
  EXPECT_EQ(json_value(s, "none_lost"), "true") << s;
  EXPECT_EQ(json_value(s, "clean_exit"), "true") << s;
  EXPECT_EQ(json_value(s, "agree"), "true") << log;
  const std::string station = read_file(dir + "/logs/groundstation.log");
  EXPECT_NE(station.find("DDS Security: identity CN=station"), std::string::npos) << station;
  const std::string events = read_file(dir + "/session/events.log");
  EXPECT_EQ(events.find(" published as robot "), std::string::npos) << events;  // no identity mismatch
  EXPECT_TRUE(std::filesystem::exists(dir + "/pki/ca/ca_cert.pem"));
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::e2e
