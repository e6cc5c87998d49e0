// GL2PS as a peer (issue 17 part 5): the scene drawn through OpenGL in an off-screen OSMesa
// context and captured by GL2PS as SVG, with its simple sort (GL2PS_SIMPLE_SORT: painter's order
// by barycentre depth) and its occlusion culling (GL2PS_OCCLUSION_CULL: primitives wholly hidden
// behind others are dropped). A painter's-order vector output: overlaps remain, and a triangle
// ordered wrongly shows through, so its picture is not a planar map; only its time is compared.
//
//   vismap_gl2ps_peer SCENE OUT.svg [--width W --height H] [--no-cull]
//
// --no-cull: the simple sort alone (every triangle written, back to front).
//
// The camera is the CLI's default for the scene (frame_scene, or the scene file's camera), so
// `vismap render SCENE -o OUT.svg` at the same size draws the same view. Prints one JSON line:
// load, draw (the GL2PS page and its SVG written, all passes until its feedback buffer fitted)
// and total ms.
#include <GL/gl.h>
#include <GL/osmesa.h>
#include <gl2ps.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/scene.h"
#include "core/util/clock.h"

namespace {

using vismap::ms_since;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "vismap_gl2ps_peer: %s\n", what.c_str());
  std::exit(1);
}

// One colour per triangle from its index (flat, as vismap's shade fill), so that GL2PS cannot
// merge neighbours into one polygon that vismap would draw as several.
void draw(const vismap::Scene& scene) {
  glBegin(GL_TRIANGLES);
  uint32_t id = 0;
  for (const vismap::Mesh& m : scene.meshes) {
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3, ++id) {
      const uint32_t h = id * 2654435761u;
      glColor3ub(GLubyte(h >> 24), GLubyte(h >> 16), GLubyte(h >> 8));
      for (int k = 0; k < 3; ++k) glVertex3fv(&m.positions[3 * size_t(m.indices[t + k])]);
    }
  }
  glEnd();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3)
    fail("usage: vismap_gl2ps_peer SCENE OUT.svg [--width W --height H] [--no-cull] [--back-faces]");
  const std::string in = argv[1], out = argv[2];
  uint32_t W = 1024, H = 1024;
  GLint options = GL2PS_OCCLUSION_CULL | GL2PS_USE_CURRENT_VIEWPORT;
  bool back_faces = false;  // --back-faces: OpenGL's back-face culling (glEnable(GL_CULL_FACE))
  for (int i = 3; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--no-cull")) options &= ~GL2PS_OCCLUSION_CULL;
    else if (!std::strcmp(argv[i], "--back-faces")) back_faces = true;
    else if (i + 1 < argc && !std::strcmp(argv[i], "--width")) W = uint32_t(std::atoi(argv[++i]));
    else if (i + 1 < argc && !std::strcmp(argv[i], "--height")) H = uint32_t(std::atoi(argv[++i]));
    else fail(std::string("unknown option ") + argv[i]);
  }
  const auto t0 = vismap::Clock::now();
  vismap::Scene scene = vismap::load_scene(in);
  vismap::Camera cam = scene.camera ? *scene.camera : vismap::frame_scene(scene, W, H);
  cam.width = W;
  cam.height = H;
  vismap::fit_near_far(cam, scene);
  const double load_ms = ms_since(t0);

  OSMesaContext ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (!ctx) fail("OSMesaCreateContextExt failed");
  std::vector<GLubyte> pixels(size_t(W) * H * 4);
  if (!OSMesaMakeCurrent(ctx, pixels.data(), GL_UNSIGNED_BYTE, GLsizei(W), GLsizei(H)))
    fail("OSMesaMakeCurrent failed");
  glViewport(0, 0, GLsizei(W), GLsizei(H));
  glMatrixMode(GL_PROJECTION);
  const vismap::Mat4 p = cam.projection_matrix(), v = cam.view();
  glLoadMatrixd(p.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(v.data());
  glEnable(GL_DEPTH_TEST);
  if (back_faces) {  // (the picture loses what an open mesh shows of its inside: the fastest mode)
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
  }
  glShadeModel(GL_FLAT);
  glClearColor(1, 1, 1, 1);

  const auto t1 = vismap::Clock::now();
  FILE* fp = std::fopen(out.c_str(), "wb");
  if (!fp) fail("cannot write " + out);
  GLint buffer = 1 << 24, state = GL2PS_OVERFLOW, passes = 0;
  while (state == GL2PS_OVERFLOW) {  // GL2PS's own loop: grow the feedback buffer until it fits
    ++passes;
    std::rewind(fp);
    gl2psBeginPage(in.c_str(), "vismap_gl2ps_peer", nullptr, GL2PS_SVG, GL2PS_SIMPLE_SORT, options,
                   GL_RGBA, 0, nullptr, 0, 0, 0, buffer, fp, out.c_str());
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    draw(scene);
    state = gl2psEndPage();
    buffer *= 2;
  }
  std::fclose(fp);
  const double draw_ms = ms_since(t1);
  if (state != GL2PS_SUCCESS && state != GL2PS_NO_FEEDBACK) fail("gl2psEndPage failed");
  OSMesaDestroyContext(ctx);
  std::printf("{\"scene\":\"%s\",\"width\":%u,\"height\":%u,\"load_ms\":%.1f,\"draw_ms\":%.1f,"
              "\"passes\":%d,\"total_ms\":%.1f}\n",
              in.c_str(), W, H, load_ms, draw_ms, passes, ms_since(t0));
  return 0;
}
