#include "core/error.h"

namespace vismap {

const char* to_string(InputErrorKind k) {
  switch (k) {
    case InputErrorKind::FileNotFound:
      return "file_not_found";
    case InputErrorKind::UnknownFormat:
      return "unknown_format";
    case InputErrorKind::Truncated:
      return "truncated";
    case InputErrorKind::ParseError:
      return "parse_error";
    case InputErrorKind::NonFiniteVertex:
      return "non_finite_vertex";
    case InputErrorKind::IndexOutOfRange:
      return "index_out_of_range";
    case InputErrorKind::EmptyMesh:
      return "empty_mesh";
    case InputErrorKind::BadScene:
      return "bad_scene";
    case InputErrorKind::BadCamera:
      return "bad_camera";
    case InputErrorKind::TooLarge:
      return "too_large";
    case InputErrorKind::TimeLimit:
      return "time_limit";
    case InputErrorKind::Cancelled:
      return "cancelled";
  }
  return "unknown";
}

static std::string compose(const std::string& file, const std::string& mesh,
                           const std::string& element, int64_t index, const std::string& msg) {
  std::string s = file.empty() ? std::string("<input>") : file;
  if (!mesh.empty()) s += ": mesh '" + mesh + "'";
  if (!element.empty()) {
    s += ": " + element;
    if (index >= 0) s += " " + std::to_string(index);
  }
  s += ": " + msg;
  return s;
}

InputError::InputError(InputErrorKind kind, std::string file, std::string mesh, std::string element,
                       int64_t index, std::string message)
    : std::runtime_error(compose(file, mesh, element, index, message)),
      kind_(kind),
      file_(std::move(file)),
      mesh_(std::move(mesh)),
      element_(std::move(element)),
      index_(index),
      detail_(std::move(message)) {}

}  // namespace vismap
