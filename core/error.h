// Typed errors for bad input and device failures. core/ never exits or aborts on
// user input: it throws one of these, and the message says where (file, mesh, element).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace vismap {

// What kind of bad input: mirrors the protocol's error codes (proto/PROTOCOL.md).
enum class InputErrorKind {
  FileNotFound,
  UnknownFormat,
  Truncated,
  ParseError,
  NonFiniteVertex,
  IndexOutOfRange,
  EmptyMesh,
  BadScene,
  BadCamera,
  TooLarge,
  TimeLimit,  // a render or load passed its time limit (RenderOptions, LoadOptions::time_limit_s)
  Cancelled,  // its caller cancelled the frame (RenderOptions::cancel, core/frame's FrameSpec)
};

const char* to_string(InputErrorKind k);

// Bad input. what() is one line: "FILE: mesh 'NAME': ELEMENT INDEX: MESSAGE"
// (parts that do not apply are left out).
class InputError : public std::runtime_error {
 public:
  InputError(InputErrorKind kind, std::string file, std::string mesh, std::string element,
             int64_t index, std::string message);
  InputErrorKind kind() const { return kind_; }
  const std::string& file() const { return file_; }
  const std::string& mesh() const { return mesh_; }
  const std::string& element() const { return element_; }
  int64_t index() const { return index_; }
  const std::string& detail() const { return detail_; }

 private:
  InputErrorKind kind_;
  std::string file_, mesh_, element_;
  int64_t index_;
  std::string detail_;
};

// OpenCL failure (program build, allocation, launch). Carries the stage name
// and, for build failures, the full build log.
class DeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace vismap
