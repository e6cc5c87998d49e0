#pragma once
namespace vismap::cli {
// `vismap check SCENE ...`: pipeline + exact reference + pixel comparison, one JSON object out.
int cmd_check(int argc, char** argv);
}  // namespace vismap::cli
