// Request routing (pure): files, API, /ws, and every error with its status; the listen address; counters.
#include "groundstation/view/requests.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace teamscan::view {
namespace {

RouteDecision route(std::string_view method, std::string_view target, bool upgrade = false, std::uint64_t body = 0) {
  static const std::set<std::string, std::less<>> files = {"index.html", "app.js", "style.css"};
  return route_request(method, target, upgrade, body, RequestLimits{},
                       [](std::string_view n) { return files.find(n) != files.end(); });
}

TEST(ViewRequests, FilesApiAndWebSocket) {
  EXPECT_EQ(route("GET", "/").route, Route::kFile);
  EXPECT_EQ(route("GET", "/").file, "index.html");
  EXPECT_EQ(route("HEAD", "/app.js").file, "app.js");
  EXPECT_EQ(route("GET", "/ws", true).route, Route::kWebSocket);
  EXPECT_EQ(route("GET", "/api/state").route, Route::kState);
  EXPECT_FALSE(route("GET", "/api/state").seq.has_value());
  EXPECT_EQ(route("GET", "/api/state?seq=17").seq, 17u);
  EXPECT_EQ(route("GET", "/api/stats").route, Route::kStats);
}

TEST(ViewRequests, ErrorsHaveTheirStatus) {
  EXPECT_EQ(route("GET", "/nope.html").status, 404);
  EXPECT_EQ(route("GET", "/../etc/passwd").status, 404);
  EXPECT_EQ(route("GET", "/.hidden").status, 404);
  EXPECT_EQ(route("GET", "/dir/app.js").status, 404);
  EXPECT_EQ(route("POST", "/").status, 405);
  EXPECT_EQ(route("PUT", "/api/state").status, 405);
  EXPECT_EQ(route("DELETE", "/ws", true).status, 405);
  EXPECT_EQ(route("GET", "/", false, 1).status, 413);
  EXPECT_EQ(route("GET", "/" + std::string(2000, 'a')).status, 414);
  EXPECT_EQ(route("GET", "/ws").status, 400);  // not an upgrade
  EXPECT_EQ(route("GET", "/api/state?seq=x").status, 400);
  EXPECT_EQ(route("GET", "/api/state?seq=").status, 400);
  EXPECT_EQ(route("GET", "/api/state?cmd=stop").status, 400);
  EXPECT_EQ(route("GET", "/api/stats?x=1").status, 400);
  EXPECT_EQ(route("GET", "*").status, 400);
  EXPECT_EQ(route("GET", "/nope.html").route, Route::kError);
  EXPECT_FALSE(route("GET", "/nope.html").error.empty());
}

TEST(ViewRequests, CountersByStatus) {
  ViewCounters c;
  for (int s : {400, 404, 404, 405, 413, 414, 431, 503}) c.count_error(s);
  EXPECT_EQ(c.malformed.load(), 1u);
  EXPECT_EQ(c.not_found.load(), 2u);
  EXPECT_EQ(c.bad_method.load(), 1u);
  EXPECT_EQ(c.oversized.load(), 3u);
  EXPECT_EQ(c.refused.load(), 1u);
  EXPECT_NE(c.json().find("\"not_found\":2"), std::string::npos);
}

TEST(ViewRequests, ListenAddress) {
  ListenAddress a;
  std::string why;
  ASSERT_TRUE(parse_listen("127.0.0.1:8080", a, why)) << why;
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 8080);
  ASSERT_TRUE(parse_listen("localhost:0", a, why)) << why;
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 0);
  EXPECT_FALSE(parse_listen("127.0.0.1", a, why));
  EXPECT_FALSE(parse_listen("127.0.0.1:", a, why));
  EXPECT_FALSE(parse_listen("127.0.0.1:65536", a, why));
  EXPECT_FALSE(parse_listen("127.0.0.1:80x", a, why));
  EXPECT_FALSE(parse_listen("256.0.0.1:80", a, why));
  EXPECT_FALSE(parse_listen("example.com:80", a, why));
  EXPECT_NE(why.find("IPv4"), std::string::npos);
}

TEST(ViewRequests, ContentTypes) {
  EXPECT_EQ(content_type_of("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(content_type_of("app.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(content_type_of("style.css"), "text/css; charset=utf-8");
  EXPECT_EQ(content_type_of("blob"), "application/octet-stream");
}

}  // namespace
}  // namespace teamscan::view
