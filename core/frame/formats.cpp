#include "core/frame/formats.h"

#include <cctype>
#include <filesystem>

namespace vismap::frame {

std::optional<OutputFormat> format_named(std::string_view name) {
  for (const FormatRow& r : kFormats)
    if (name == r.name) return r.format;
  return std::nullopt;
}

std::optional<OutputFormat> format_of_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  for (const FormatRow& r : kFormats)
    if (r.extension && ext == r.extension) return r.format;
  return std::nullopt;
}

std::string file_format_names() {
  std::string s, last;
  for (const FormatRow& r : kFormats) {
    if (!r.extension) continue;
    if (!last.empty()) s += (s.empty() ? "" : ", ") + last;
    last = r.name;
  }
  return s.empty() ? last : s + " or " + last;
}

std::string file_format_extensions() {
  std::string s;
  for (const FormatRow& r : kFormats)
    if (r.extension) s += (s.empty() ? "" : " ") + std::string(r.extension);
  return s;
}

}  // namespace vismap::frame
