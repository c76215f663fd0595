// Robots 1 and 2's DDS bridges on the test's domain, as their daemons would publish: the station HIL
// tests' robots (one set-up instead of a copy per test).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "onboard/bridge/bridge.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::test {

inline void start_robot_bridges(std::vector<onboard::DdsBridge>& robots) {
  for (std::uint32_t id : {1u, 2u}) {
    onboard::DdsBridgeOptions o;
    o.robot_id = id;
    o.domain_id = test_domain_id();
    auto b = onboard::DdsBridge::create(o);
    ASSERT_TRUE(b.ok()) << b.error().what;
    robots.push_back(std::move(b.value()));
  }
}

}  // namespace teamscan::test
