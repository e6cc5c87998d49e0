// The output formats, one row each: the one list that `vismap render`'s --format and -o
// extension, vismapd's hello.format and the frame encoders (encoders.cpp) follow. A new format is
// a row here and its encoder in make_encoder.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace vismap::frame {

enum class OutputFormat : uint8_t { Svg, Pdf, Eps, Png, Bin, Compact, Delta };

struct FormatRow {
  OutputFormat format;
  const char* name;       // --format, hello.format, frame.format, the metrics' format label
  const char* extension;  // an output file's (any case); nullptr: none (a frame of a stream)
  bool binary;            // bytes, not text (a binary WebSocket message)
  bool carries_attributes;  // can carry barycentrics and 1/w (RenderOptions::attributes)
  bool lines;               // can carry a line drawing (style lines or fill+lines)
};

inline constexpr std::array<FormatRow, 7> kFormats{{
    {OutputFormat::Svg, "svg", ".svg", false, false, true},
    {OutputFormat::Pdf, "pdf", ".pdf", true, false, true},
    {OutputFormat::Eps, "eps", ".eps", true, false, true},
    {OutputFormat::Png, "png", ".png", true, false, true},
    {OutputFormat::Bin, "bin", ".bin", true, true, true},
    {OutputFormat::Compact, "compact", ".vmc", true, false, false},
    {OutputFormat::Delta, "delta", nullptr, true, false, false},
}};

static_assert(
    [] {
      for (size_t i = 0; i < kFormats.size(); ++i)
        if (static_cast<size_t>(kFormats[i].format) != i) return false;
      return true;
    }(),
    "kFormats is indexed by OutputFormat");

constexpr const FormatRow& format_row(OutputFormat f) { return kFormats[static_cast<size_t>(f)]; }

// The format of that name ("svg", "compact", ...); none for an unknown name.
std::optional<OutputFormat> format_named(std::string_view name);
// The format a file's extension names (any case): .svg .pdf .eps .png .bin .vmc; none otherwise.
std::optional<OutputFormat> format_of_path(const std::string& path);
// The names of the formats written to files, for messages: "svg, pdf, eps, png, bin or compact".
std::string file_format_names();
// Their extensions: ".svg .pdf .eps .png .bin .vmc".
std::string file_format_extensions();

}  // namespace vismap::frame
