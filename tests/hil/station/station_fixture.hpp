// A Station in the test's process on a session folder of its own (removed at the end), on the test's DDS
// domain, and a loop that polls it and publishes the team state until a condition holds.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "common/clock.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::test {

struct StationFixture {
  std::string root;
  std::optional<station::SessionStore> store;
  station::LastPoseTeamSource team;
  std::unique_ptr<station::Station> station;

  // `options`: the test's own; its domain is set to the test's.
  explicit StationFixture(station::StationOptions options = {}) {
    char tmpl[] = "/tmp/teamscan-station-XXXXXX";
    root = ::mkdtemp(tmpl);
    auto s = station::SessionStore::open(root + "/session");
    if (!s) ADD_FAILURE() << s.error().what;
    store.emplace(std::move(s.value()));
    options.domain_id = test_domain_id();
    auto st = station::Station::create(options, *store, team);
    if (!st) ADD_FAILURE() << st.error().what;
    station = std::move(st.value());
  }
  ~StationFixture() { std::filesystem::remove_all(root); }

  // Polls the station (and publishes team) until pred() or timeout; true if pred held.
  template <class P>
  bool run_until(P pred, Duration timeout) {
    const Time deadline = now_monotonic() + timeout;
    while (now_monotonic() < deadline) {
      station->poll(std::chrono::milliseconds(20));
      station->publish_team_if_due(now_monotonic());
      if (pred()) return true;
    }
    return false;
  }
};

}  // namespace teamscan::test
