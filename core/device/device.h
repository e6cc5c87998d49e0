// OpenCL devices as the user names them (`vismap devices`, --device, $VISMAP_DEVICE).
#pragma once

#include <string>
#include <vector>

namespace vismap {

struct DeviceInfo {
  std::string platform, name, version;
  bool is_gpu = false;
  std::string id;  // "P:D" platform and device index
};

std::vector<DeviceInfo> list_devices();

}  // namespace vismap
