// Errors that own their message (common/error_message.hpp) and literal ones (common/result.hpp).
#include "common/error_message.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <string>

namespace teamscan {
namespace {

Result<int> open_config(const std::string& path) { return make_error("cannot open " + path, ENOENT, 7); }

TEST(ErrorMessage, LiteralMessageIsTheLiteral) {
  const char* const text = "lms200: bad CRC";
  const Error e{text, 0, 3};
  EXPECT_EQ(e.what, text);
  EXPECT_EQ(e.detail, 3);
  EXPECT_EQ(e.owned, nullptr);
}

TEST(ErrorMessage, BuiltMessageNamesWhatFailedAndOutlivesItsSource) {
  Result<int> r = [] {
    std::string path = "/etc/teamscan/groundstation.toml";
    return open_config(path);  // the path's string dies here
  }();
  ASSERT_FALSE(r.ok());
  EXPECT_STREQ(r.error().what, "cannot open /etc/teamscan/groundstation.toml");
  EXPECT_EQ(r.error().sys_errno, ENOENT);
  EXPECT_EQ(r.error().detail, 7);
}

TEST(ErrorMessage, CopiesShareTheMessage) {
  Error copy;
  {
    const Error original = make_error(std::string("robot ") + std::to_string(12) + ": unknown");
    copy = original;
  }
  EXPECT_STREQ(copy.what, "robot 12: unknown");
}

TEST(ErrorMessage, ResultCopiedMovedAndAssignedKeepsTheMessage) {
  Result<int> a = open_config("a.toml");
  Result<int> b = a;
  Result<int> c = std::move(a);
  EXPECT_STREQ(a.error().what, "cannot open a.toml");  // NOLINT(bugprone-use-after-move): the error is copied
  Result<int> d = 5;
  d = b;
  b = 1;
  EXPECT_STREQ(c.error().what, "cannot open a.toml");
  EXPECT_STREQ(d.error().what, "cannot open a.toml");
  EXPECT_EQ(b.value(), 1);
}

TEST(ErrorMessage, ContextGoesInFrontAndKeepsErrnoAndDetail) {
  const Error inner = make_error("bad header", EIO, 12);
  const Error outer = with_context("session/points.pcd", inner);
  EXPECT_STREQ(outer.what, "session/points.pcd: bad header");
  EXPECT_EQ(outer.sys_errno, EIO);
  EXPECT_EQ(outer.detail, 12);
  EXPECT_STREQ(with_context("poses.csv", Error{"no rows"}).what, "poses.csv: no rows");
}

TEST(ErrorMessage, EmptyMessageIsEmptyNotNull) {
  const Error e = make_error("");
  ASSERT_NE(e.what, nullptr);
  EXPECT_STREQ(e.what, "");
}

}  // namespace
}  // namespace teamscan
