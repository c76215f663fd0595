// Options the fusion core refuses (from a command line or a calibration file) come back from
// `teamscan eval`'s and `teamscan calibrate`'s entry points as an error that names the option; they
// never abort the program.
#include <gtest/gtest.h>

#include <string>

#include "groundstation/fusion/calibration.hpp"
#include "groundstation/fusion/evaluation.hpp"

namespace teamscan::fusion {
namespace {

Dataset one_robot() {
  Dataset d;
  d.scenario = "errors";
  d.robots.push_back(DatasetRobot{});
  d.robots.back().id = 1;
  return d;
}

bool mentions(const Error& e, const char* text) { return std::string(e.what).find(text) != std::string::npos; }

TEST(EvaluationErrors, RegistrationWindowOfZeroIsAnErrorNamingTheOption) {
  EvalOptions o;
  o.methods = parse_methods("position", std::nullopt, std::nullopt).value();
  o.registration = true;
  o.registration_options.window_s = 0.0;
  const Result<EvalReport> r = evaluate(one_robot(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "window_s")) << r.error().what;
  EXPECT_TRUE(mentions(r.error(), "position")) << r.error().what;  // the method it was run for
}

TEST(EvaluationErrors, TeamLagOutOfRangeIsAnError) {
  CoreRunOptions run;
  run.tracker.team_lag_s = 99.0;
  const Result<CoreRun> r = run_through_core(one_robot(), "visibility", mapping::MethodOptions{}, run);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "team_lag_s")) << r.error().what;
  EXPECT_FALSE(decide_through_core(one_robot(), "visibility", mapping::MethodOptions{}, run.tracker).ok());
}

TEST(EvaluationErrors, UnknownMethodIsAnError) {
  const Result<CoreRun> r = run_through_core(one_robot(), "no-such-method", mapping::MethodOptions{}, CoreRunOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "no-such-method")) << r.error().what;
}

TEST(EvaluationErrors, CalibrationWithARefusedRegistrationIsAnError) {
  CalibrationOptions o;
  o.registration.match_delay_s = 60.0;
  const Result<Calibration> r = calibrate_drive(one_robot(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "match_delay_s")) << r.error().what;
}

TEST(EvaluationErrors, PosesToDecideWithAreCheckedAgainstTheScansAndTheRegistration) {
  Dataset d = one_robot();
  d.scans.push_back(ScanRecord{});
  d.scans.back().robot = 1;
  CoreRunOptions run;
  run.decide_with.assign(2, Pose2{});  // two poses for one scan row
  Result<CoreRun> r = run_through_core(d, "visibility", mapping::MethodOptions{}, run);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "one per row")) << r.error().what;
  run.decide_with.assign(1, Pose2{});
  run.registration = true;
  r = run_through_core(d, "visibility", mapping::MethodOptions{}, run);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r.error(), "registration")) << r.error().what;
  run.registration = false;
  EXPECT_TRUE(run_through_core(d, "visibility", mapping::MethodOptions{}, run).ok());
}

TEST(EvaluationErrors, GoodOptionsStillRun) {
  EvalOptions o;
  o.methods = parse_methods("position", std::nullopt, std::nullopt).value();
  const Result<EvalReport> r = evaluate(one_robot(), o);
  ASSERT_TRUE(r.ok()) << r.error().what;
  EXPECT_EQ(r.value().methods.size(), 1u);
}

}  // namespace
}  // namespace teamscan::fusion
