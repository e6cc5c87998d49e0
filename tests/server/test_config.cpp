// vismapd's configuration: flags and the JSON config file, and what the binary refuses to start
// with. The binary tests run build/server/vismapd itself (VISMAPD_PATH).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "server/config.h"

using namespace vismap::server;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("vismapd_config_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
    return (path / name).string();
  }
};

bool parse(Config& cfg, std::vector<std::string> args) {
  std::vector<char*> argv{const_cast<char*>("vismapd")};
  for (auto& a : args) argv.push_back(a.data());
  std::string usage;
  return parse_args(cfg, static_cast<int>(argv.size()), argv.data(), usage);
}

// Runs vismapd with `args` for at most 10 s; returns its exit status (124: still serving).
int run_vismapd(const std::string& args) {
  std::string cmd = "timeout 10 " + std::string(VISMAPD_PATH) + " --port 0 --log-level off " +
                    args + " 2>/dev/null";
  int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

// Issue 15, bug 6: a config file whose token_file was empty or whitespace started the server
// with "auth": false (the same file given to --token-file refused to start). Both paths refuse.
TEST(ConfigTest, EmptyTokenFileRefusesToStartInBothPaths) {
  TempDir d;
  for (const std::string& content : {std::string(), std::string(" \n\t\r\n")}) {
    std::string token = d.file("token", content);
    std::string conf = d.file("conf.json", "{\"token_file\":\"" + token + "\"}");
    Config a, b;
    EXPECT_THROW(parse(a, {"--config", conf}), std::runtime_error);
    EXPECT_THROW(parse(b, {"--token-file", token}), std::runtime_error);
    EXPECT_THROW(apply_json(a, "{\"token_file\":\"" + token + "\"}", "test"), std::runtime_error);
    EXPECT_EQ(run_vismapd("--config " + conf), 1);
    EXPECT_EQ(run_vismapd("--token-file " + token), 1);
  }
}

TEST(ConfigTest, TokenFileIsTrimmed) {
  TempDir d;
  std::string token = d.file("token", "\t s3cret \n");
  Config a, b;
  ASSERT_TRUE(parse(a, {"--token-file", token}));
  EXPECT_EQ(a.token, "s3cret");
  apply_json(b, "{\"token_file\":\"" + token + "\"}", "test");
  EXPECT_EQ(b.token, "s3cret");
}

// frame_level: 0 (the coder's default) ... 19, from the config file; anything else refused.
TEST(ConfigTest, FrameLevelIsCheckedAndApplied) {
  Config a;
  EXPECT_EQ(a.frame_level, 0);
  apply_json(a, "{\"frame_level\": 19}", "test");
  EXPECT_EQ(a.frame_level, 19);
  for (const char* bad :
       {"{\"frame_level\": 20}", "{\"frame_level\": -1}", "{\"frame_level\": \"max\"}"}) {
    Config b;
    try {
      apply_json(b, bad, "test");
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("frame_level"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
