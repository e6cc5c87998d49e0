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

// Runs vismapd with `args` for at most `seconds`; returns its exit status (124: still serving).
int run_vismapd(const std::string& args, int seconds = 10) {
  std::string cmd = "timeout " + std::to_string(seconds) + " " + std::string(VISMAPD_PATH) +
                    " --port 0 --log-level off " + args + " 2>/dev/null";
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

// Issue 45, item 7: every setting is range-checked, with an error naming the key. On a3eef30
// `renderers: -1` became 2^32 - 1 render workers (the process aborted), and these were taken:
// max_scene_bytes -5 (2^64 - 5), drain_timeout_s -1, frame_level 2.5 (2), max_viewport 65536
// (past the kernels' 16384).
std::string refusal(const std::string& json_text) {
  Config c;
  try {
    apply_json(c, json_text, "test.json");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(ConfigTest, IssueCasesAreRefusedNamingTheKey) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"renderers": -1})", "'renderers'"},
      {R"({"limits": {"max_scene_bytes": -5}})", "'limits.max_scene_bytes'"},
      {R"({"drain_timeout_s": -1})", "'drain_timeout_s'"},
      {R"({"frame_level": 2.5})", "'frame_level'"},
      {R"({"limits": {"max_viewport": 65536}})", "'limits.max_viewport'"},
  };
  for (const auto& [text, key] : cases) {
    std::string e = refusal(text);
    EXPECT_NE(e.find(key), std::string::npos) << text << " -> '" << e << "'";
    EXPECT_NE(e.find("test.json"), std::string::npos) << e;
  }
}

// Every key, with values on both sides of its ends and of the wrong type.
TEST(ConfigTest, EveryKeyIsRangeChecked) {
  struct Case {
    const char* key;  // "limits.x" goes under "limits"
    std::vector<const char*> good, bad;
  };
  const std::vector<Case> cases = {
      {"address", {R"("0.0.0.0")"}, {R"("")", "1", "null"}},
      {"port", {"0", "65535"}, {"-1", "65536", "80.5", R"("80")"}},
      {"library", {R"("/tmp")", R"("")"}, {"1", "true"}},
      {"www", {R"("")"}, {"[]"}},
      {"device", {R"("cpu")"}, {"0"}},
      {"renderers", {"1", "64"}, {"0", "-1", "65", "1.5", "4294967297", R"("2")"}},
      {"io_threads", {"1", "256"}, {"0", "-2", "257", "2.0"}},
      {"load_threads", {"1"}, {"0", "-1", "1e3"}},
      {"encode_threads", {"3"}, {"0", "-1", "true"}},
      {"drain_timeout_s", {"0", "0.5", "1000000"}, {"-1", "-0.001", "1e7", R"("10")"}},
      {"log_level", {R"("info")", R"("warn")", R"("off")"}, {R"("debug")", "1"}},
      {"permessage_deflate", {"true", "false"}, {"1", R"("on")"}},
      {"deflate_level", {"1", "9"}, {"0", "10", "-1", "5.5"}},
      {"deflate_window_bits", {"9", "15"}, {"8", "16"}},
      {"deflate_mem_level", {"1", "9"}, {"0", "10"}},
      {"frame_level", {"0", "19"}, {"-1", "20", "2.5", "3.0"}},
      {"limits.max_message_bytes", {"0", "4096"}, {"-1", "9007199254740993", "1.5"}},
      {"limits.max_control_bytes", {"1", "65536"}, {"0", "-5"}},
      {"limits.max_scene_bytes", {"1", "9007199254740992"}, {"0", "-5", "18446744073709551615"}},
      {"limits.max_triangles", {"1", "4294967295"}, {"0", "-1", "4294967296"}},
      {"limits.max_session_bytes", {"1"}, {"0", "-1"}},
      {"limits.render_memory_bytes", {"0", "1048576"}, {"-1", "0.5"}},
      {"limits.max_sessions", {"1", "100000"}, {"0", "-1", "100001"}},
      {"limits.max_connections", {"1"}, {"0", "-1", "4294967296"}},
      {"limits.max_connections_per_address", {"0", "2"}, {"-1", "4294967296"}},
      {"limits.max_viewport", {"1", "16384"}, {"0", "-1", "16385", "65536", "1024.5"}},
      {"limits.handshake_timeout_s", {"0.3", "5"}, {"0", "-1", "2e6"}},
      {"limits.idle_timeout_s", {"0.5", "60"}, {"0", "-60", R"("60")"}},
      {"limits.render_time_limit_s", {"0", "1e-6", "30"}, {"-1", "1e9"}},
  };
  for (const Case& c : cases) {
    std::string key = c.key;
    auto doc = [&](const char* value) {
      if (key.rfind("limits.", 0) == 0)
        return std::string(R"({"limits": {")") + key.substr(7) + R"(": )" + value + "}}";
      return std::string(R"({")") + key + R"(": )" + value + "}";
    };
    for (const char* v : c.good) EXPECT_EQ(refusal(doc(v)), "") << doc(v);
    for (const char* v : c.bad) {
      std::string e = refusal(doc(v));
      EXPECT_NE(e.find("'" + key + "'"), std::string::npos) << doc(v) << " -> '" << e << "'";
    }
  }
}

// The flags set the same keys with the same ranges (--renderers 0 became 1 silently before).
TEST(ConfigTest, FlagsAreRangeCheckedLikeTheirKeys) {
  const std::vector<std::vector<std::string>> bad = {
      {"--renderers", "0"},
      {"--renderers", "-1"},
      {"--renderers", "65"},
      {"--renderers", "2.5"},
      {"--max-sessions", "0"},
      {"--max-sessions", "100001"},
      {"--port", "65536"},
      {"--port", "http"},
      {"--log-level", "debug"},
      {"--address", ""},
      {"--max-sessions", "99999999999999999999999"},
  };
  for (const auto& args : bad) {
    Config c;
    try {
      parse(c, args);
      ADD_FAILURE() << args[0] << " " << args[1] << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(args[0]), std::string::npos) << e.what();
    }
  }
  Config c;
  ASSERT_TRUE(parse(c, {"--renderers", "4", "--max-sessions", "7", "--port", "0", "--library",
                        "123", "--log-level", "warn"}));
  EXPECT_EQ(c.renderers, 4u);
  EXPECT_EQ(c.limits.max_sessions, 7u);
  EXPECT_EQ(c.library, "123");
  EXPECT_EQ(c.log_level, "warn");
}

// A Config built in code is checked when the Server is made (the tests and embedders build
// them so), with the same messages.
TEST(ConfigTest, ServerRefusesAnOutOfRangeConfig) {
  Config c;
  c.limits.max_viewport = 65536;
  try {
    validate(c, "config");
    ADD_FAILURE() << "max_viewport 65536 was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'limits.max_viewport'"), std::string::npos) << e.what();
  }
  c = Config{};
  c.limits.idle_timeout_s = 0;
  EXPECT_THROW(validate(c, "config"), std::runtime_error);
  EXPECT_NO_THROW(validate(Config{}, "config"));
}

// The binary exits 1 with the key named, not an abort (renderers -1 was SIGABRT), for each
// issue case; and a config at the ends of the ranges serves.
TEST(ConfigTest, BinaryRefusesOutOfRangeSettings) {
  TempDir d;
  for (const char* text : {R"({"renderers": -1})", R"({"limits": {"max_scene_bytes": -5}})",
                           R"({"drain_timeout_s": -1})", R"({"frame_level": 2.5})",
                           R"({"limits": {"max_viewport": 65536}})"}) {
    std::string conf = d.file("bad.json", text);
    EXPECT_EQ(run_vismapd("--config " + conf), 1) << text;
  }
  std::string conf = d.file("ends.json", R"({"renderers": 1, "drain_timeout_s": 0,
      "limits": {"max_viewport": 16384, "render_memory_bytes": 0, "render_time_limit_s": 0}})");
  EXPECT_EQ(run_vismapd("--config " + conf, 3), 124);  // still serving when timeout stops it
}

}  // namespace
