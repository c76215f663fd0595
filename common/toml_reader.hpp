// The one checked reader of teamscan's TOML configs on top of toml++: typed values by section and key,
// required keys, ranges, unknown keys refused; the first error is kept as "<section>.<key>: <why>
// (line N)". Header-only and exception-free, so both the robot daemon (-fno-exceptions, toml++ with
// TOML_EXCEPTIONS 0, defined before its first include of toml++) and the ground station use it.
#pragma once

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace teamscan {

class TomlReader {
 public:
  TomlReader(const toml::table& root, std::string& message) : root_{root}, message_{message} {}

  [[nodiscard]] bool failed() const { return failed_; }
  [[nodiscard]] long line() const { return line_; }

  // Records the first error (later ones are dropped: one error, the first, names its key). Returns false.
  bool fail(const std::string& key, const std::string& why, const toml::node* at = nullptr) {
    if (failed_) return false;
    failed_ = true;
    message_ = key + ": " + why;
    if (at != nullptr) {
      line_ = static_cast<long>(at->source().begin.line);
      message_ += " (line " + std::to_string(line_) + ")";
    }
    return false;
  }

  // The section table at a dotted path ("team.kalman"), or nullptr if absent (a required section that
  // is absent is an error).
  const toml::table* section(const char* path, bool required) {
    const toml::node* n = root_.at_path(path).node();
    if (n == nullptr) {
      if (required) fail(path, "missing section [" + std::string(path) + "]");
      return nullptr;
    }
    if (!n->is_table()) {
      fail(path, "must be a table [" + std::string(path) + "]", n);
      return nullptr;
    }
    return n->as_table();
  }

  // Refuses keys that are not in `allowed` (a typo would otherwise silently keep a default).
  void only(const toml::table* t, const char* sect, std::initializer_list<const char*> allowed) {
    if (t == nullptr) return;
    for (auto&& [k, v] : *t)
      if (!listed(k.str(), allowed)) fail(std::string(sect) + "." + std::string(k.str()), "unknown key", &v);
  }

  void top_level(std::initializer_list<const char*> allowed) {
    for (auto&& [k, v] : root_)
      if (!listed(k.str(), allowed)) fail(std::string(k.str()), "unknown section or key", &v);
  }

  // Typed reads: true when the key is present and of the right type (then `out` holds it); false when
  // absent (an error if required) or of the wrong type (an error).
  bool number(const toml::table* t, const char* sect, const char* key, double& out, bool required) {
    const toml::node* n = find(t, sect, key, required);
    if (n == nullptr) return false;
    double v = 0;
    if (const auto* f = n->as_floating_point()) v = f->get();
    else if (const auto* i = n->as_integer()) v = static_cast<double>(i->get());
    else return fail(name(sect, key), "must be a number", n);
    if (!std::isfinite(v)) return fail(name(sect, key), "must be finite", n);
    out = v;
    return true;
  }

  bool integer(const toml::table* t, const char* sect, const char* key, std::int64_t& out, bool required) {
    const toml::node* n = find(t, sect, key, required);
    if (n == nullptr) return false;
    const auto* i = n->as_integer();
    if (i == nullptr) return fail(name(sect, key), "must be an integer", n);
    out = i->get();
    return true;
  }

  bool boolean(const toml::table* t, const char* sect, const char* key, bool& out) {
    const toml::node* n = find(t, sect, key, false);
    if (n == nullptr) return false;
    const auto* b = n->as_boolean();
    if (b == nullptr) return fail(name(sect, key), "must be true or false", n);
    out = b->get();
    return true;
  }

  bool string(const toml::table* t, const char* sect, const char* key, std::string& out, bool required) {
    const toml::node* n = find(t, sect, key, required);
    if (n == nullptr) return false;
    const auto* s = n->as_string();
    if (s == nullptr) return fail(name(sect, key), "must be a string", n);
    out = s->get();
    return true;
  }

  // An array of strings (may be empty).
  bool strings(const toml::table* t, const char* sect, const char* key, std::vector<std::string>& out) {
    const toml::node* n = find(t, sect, key, false);
    if (n == nullptr) return false;
    const auto* a = n->as_array();
    if (a == nullptr) return fail(name(sect, key), "must be an array of strings", n);
    std::vector<std::string> v;
    for (const toml::node& e : *a) {
      const auto* s = e.as_string();
      if (s == nullptr) return fail(name(sect, key), "must be an array of strings", &e);
      v.push_back(s->get());
    }
    out = std::move(v);
    return true;
  }

  // An array of integers, each in [lo, hi] (may be empty); `out` keeps its value when absent or wrong.
  bool integers_in(const toml::table* t, const char* sect, const char* key, std::vector<std::int64_t>& out,
                   std::int64_t lo, std::int64_t hi) {
    const toml::node* n = find(t, sect, key, false);
    if (n == nullptr) return false;
    const auto* a = n->as_array();
    if (a == nullptr) return fail(name(sect, key), "must be an array of integers", n);
    std::vector<std::int64_t> v;
    for (const toml::node& e : *a) {
      const auto* i = e.as_integer();
      if (i == nullptr) return fail(name(sect, key), "must be an array of integers", &e);
      if (i->get() < lo || i->get() > hi) {
        return fail(name(sect, key), "each must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                         std::to_string(i->get()), &e);
      }
      v.push_back(i->get());
    }
    out = std::move(v);
    return true;
  }

  // An optional number in (lo, hi] ([lo, hi] if lo_closed); `out` keeps its value when absent or wrong.
  bool number_in(const toml::table* t, const char* sect, const char* key, double& out, double lo, double hi,
                 bool lo_closed = false) {
    double v = out;
    if (!number(t, sect, key, v, false)) return false;
    if (!(lo_closed ? v >= lo : v > lo) || v > hi) {
      std::ostringstream m;
      m << "must be in " << (lo_closed ? "[" : "(") << lo << ", " << hi << "], got " << v;
      return fail(name(sect, key), m.str(), node(t, key));
    }
    out = v;
    return true;
  }

  // An optional integer in [lo, hi].
  bool integer_in(const toml::table* t, const char* sect, const char* key, std::int64_t& out, std::int64_t lo,
                  std::int64_t hi) {
    std::int64_t v = out;
    if (!integer(t, sect, key, v, false)) return false;
    if (v < lo || v > hi) {
      return fail(name(sect, key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                       std::to_string(v), node(t, key));
    }
    out = v;
    return true;
  }

  // The node of a key (for errors that point at its line).
  const toml::node* node(const toml::table* t, const char* key) const { return t == nullptr ? nullptr : t->get(key); }

 private:
  // (Not a lambda over the structured binding: clang 14, used by the fuzz preset, cannot capture one.)
  static bool listed(std::string_view key, std::initializer_list<const char*> allowed) {
    for (const char* a : allowed)
      if (key == a) return true;
    return false;
  }
  static std::string name(const char* sect, const char* key) { return std::string(sect) + "." + key; }
  const toml::node* find(const toml::table* t, const char* sect, const char* key, bool required) {
    const toml::node* n = t == nullptr ? nullptr : t->get(key);
    if (n == nullptr && required) fail(name(sect, key), "missing");
    return n;
  }

  const toml::table& root_;
  std::string& message_;
  bool failed_ = false;
  long line_ = 0;
};

}  // namespace teamscan
