// Whitespace-separated tokens with line numbers, for the text formats (PLY ascii, OFF, OBJ).
#pragma once

#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>

namespace vismap::detail {

class TextCursor {
 public:
  explicit TextCursor(std::string_view text, size_t pos = 0, int64_t line = 1)
      : s_(text), pos_(pos), line_(line) {}

  // Next token on any line ("" at the end of the text).
  std::string_view token() {
    skip_space(true);
    return take();
  }
  // Next token on the current line ("" at the end of the line).
  std::string_view token_on_line() {
    skip_space(false);
    return take();
  }
  // Skips the rest of the current line, including its newline.
  void next_line() {
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    if (pos_ < s_.size()) {
      ++pos_;
      ++line_;
    }
  }
  bool at_end() {
    skip_space(true);
    return pos_ >= s_.size();
  }
  bool at_line_end() {
    skip_space(false);
    return pos_ >= s_.size() || s_[pos_] == '\n';
  }
  int64_t line() const { return line_; }
  size_t pos() const { return pos_; }
  // '#' starts a comment to the end of the line (OFF, OBJ).
  bool hash_comments = false;

 private:
  void skip_space(bool newlines) {
    while (pos_ < s_.size()) {
      char c = s_[pos_];
      if (c == '\n') {
        if (!newlines) return;
        ++line_;
      } else if (c == '#' && hash_comments) {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
        continue;
      } else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') {
        return;
      }
      ++pos_;
    }
  }
  std::string_view take() {
    size_t b = pos_;
    while (pos_ < s_.size()) {
      char c = s_[pos_];
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v') break;
      if (c == '#' && hash_comments) break;
      ++pos_;
    }
    return s_.substr(b, pos_ - b);
  }

  std::string_view s_;
  size_t pos_;
  int64_t line_;
};

// Full-token number parsing; false when the token is not (entirely) a number.
// Accepts "nan" and "inf" so that they are reported as non-finite vertices, not parse errors.
inline bool parse_number(std::string_view t, double& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && !t.empty();
}
inline bool parse_number(std::string_view t, float& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  if (r.ec == std::errc::result_out_of_range) {  // denormal or overflow: let double decide
    double d;
    if (!parse_number(t, d)) return false;
    out = static_cast<float>(d);
    return true;
  }
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && !t.empty();
}
inline bool parse_number(std::string_view t, int64_t& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && !t.empty();
}

inline std::string quote(std::string_view t) {
  if (t.size() > 40) return "'" + std::string(t.substr(0, 40)) + "...'";
  return "'" + std::string(t) + "'";
}

}  // namespace vismap::detail
