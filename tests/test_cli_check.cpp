// `vismap check` end to end: one JSON object with the documented keys, --pixels skips the exact
// reference, the exit status reports a figure over its tolerance, and --lines measures a drawing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

namespace {

struct Out {
  int status = -1;
  std::string out;
};

Out check(const std::string& args) {
  std::string cmd = std::string(VISMAP_CLI) + " check " + args + " 2>/dev/null";
  Out r;
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  int rc = pclose(p);
  r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return r;
}

const std::string kData = std::string(VISMAP_SOURCE_DIR) + "/data/";

TEST(CliCheck, PrintsAllFiguresForAStiffCase) {
  Out r = check(kData + "stiff/vertex_on_edge.json --width 200 --height 200");
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  for (const char* k :
       {"area_error", "overlap_area", "wrong_source", "pixel_error", "pipeline_ms", "reference_ms",
        "coverage_error", "outside_source", "fragments", "screen_triangles"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["area_error"].get<double>(), 0.0);
  EXPECT_EQ(j["overlap_area"].get<double>(), 0.0);
  EXPECT_EQ(j["width"].get<int>(), 200);
  EXPECT_TRUE(j["over_tolerance"].empty());
}

TEST(CliCheck, PixelsSkipTheReference) {
  Out r = check(kData + "bunny.ply --pixels 256 --width 256 --height 256");
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["area_error"].is_null());
  EXPECT_TRUE(j["reference_ms"].is_null());
  EXPECT_EQ(j["pixels"].get<int>(), 256);
  EXPECT_LT(j["pixel_error"].get<double>(), 1e-3);
  EXPECT_EQ(j["overlap_area"].get<double>(), 0.0);
}

TEST(CliCheck, OverToleranceExitsWithFour) {
  // Coplanar triangles whose tie-rule and crossing orders are cyclic: the reference has no answer
  // there (tie_cycle_area 2.5e-11 of the area), which is allowed for, but not under --strict.
  EXPECT_EQ(check(kData + "stiff/tie_cycle.json").status, 0);
  Out r = check(kData + "stiff/tie_cycle.json --strict");
  EXPECT_EQ(r.status, 4) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_FALSE(j["over_tolerance"].empty());
}

// --lines: the drawing against the 4 x 4 supersampled id raster, recall and precision within
// 1.5 px; the same drawing written as SVG and read back (--lines-from) scores alike, and with a
// line planted where no surfaces meet (a mutation) its precision falls.
TEST(CliCheck, LinesMeasureTheDrawingAndCatchAPlantedLine) {
  const std::string scene = kData + "bunny.ply --width 512 --height 512";
  Out r = check(scene + " --pixels 512 --lines");
  ASSERT_EQ(r.status, 0) << r.out;
  auto l = nlohmann::json::parse(r.out)["lines"];
  for (const char* k : {"chains", "contour_edges", "unplaced_edges", "samples_per_pixel",
                        "radius_px", "reference_points", "recall", "line_px", "precision"})
    EXPECT_TRUE(l.contains(k)) << k;
  EXPECT_EQ(l["samples_per_pixel"].get<int>(), 16);
  EXPECT_EQ(l["intersection_edges"].get<int>(), 0);
  EXPECT_EQ(l["unplaced_edges"].get<int>(), 0);
  EXPECT_GE(l["recall"].get<double>(), 0.99);
  EXPECT_GE(l["precision"].get<double>(), 0.995);

  char dir[] = "/tmp/vismap_check_lines_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string svg = std::string(dir) + "/bunny.svg", bad = std::string(dir) + "/planted.svg";
  const std::string render = std::string(VISMAP_CLI) + " render " + kData +
                             "bunny.ply --width 512 --height 512 --style lines -o " + svg +
                             " 2>/dev/null";
  ASSERT_EQ(std::system(render.c_str()), 0);
  Out ours = check(scene + " --pixels 512 --lines-from " + svg);
  ASSERT_EQ(ours.status, 0) << ours.out;
  auto lo = nlohmann::json::parse(ours.out)["lines"];
  EXPECT_NEAR(lo["precision"].get<double>(), l["precision"].get<double>(), 1e-3);
  EXPECT_NEAR(lo["recall"].get<double>(), l["recall"].get<double>(), 1e-3);
  // A 40 px contour across the bunny's flank, where its surface is smooth.
  std::FILE* in = std::fopen(svg.c_str(), "rb");
  ASSERT_NE(in, nullptr);
  std::string text;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, in)) > 0) text.append(buf, n);
  std::fclose(in);
  const size_t at = text.find("<g class=\"contour\"");
  ASSERT_NE(at, std::string::npos);
  text.insert(text.find('>', at) + 1, "<path d=\"M300 330l40 0\"/>");
  std::FILE* outf = std::fopen(bad.c_str(), "wb");
  std::fwrite(text.data(), 1, text.size(), outf);
  std::fclose(outf);
  Out planted = check(scene + " --pixels 512 --lines-from " + bad);
  ASSERT_EQ(planted.status, 0) << planted.out;
  auto lp = nlohmann::json::parse(planted.out)["lines"];
  EXPECT_NEAR(lp["line_px"].get<double>() - lo["line_px"].get<double>(), 40, 1e-6);
  EXPECT_LT(lp["precision"].get<double>(), 0.99) << "the planted line is not caught";
  std::remove(svg.c_str());
  std::remove(bad.c_str());
  rmdir(dir);
}

TEST(CliCheck, UsageErrors) {
  EXPECT_EQ(check("").status, 2);
  EXPECT_EQ(check(kData + "bunny.ply --pixels 0").status, 2);
  EXPECT_EQ(check(kData + "bunny.ply --fov-y 30 --ortho 2").status, 2);
  EXPECT_EQ(check(kData + "bunny.ply --lines --min-length ridge=3").status, 2);
  EXPECT_EQ(check(kData + "bunny.ply --lines --min-length -1").status, 2);
  EXPECT_EQ(check(kData + "bunny.ply --lines --crease-smooth maybe").status, 2);
}

}  // namespace
