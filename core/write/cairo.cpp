// PDF, EPS and PNG writers through cairo (core/write/cairo.h).
//
// The paths are the SVG writer's (core/write/paths.h: one path per source triangle, vertices
// rounded to 1/100 px, the same colours), drawn with cairo's nonzero fill, as the SVG's. Seams
// (Fill::Shade): each path is stroked in its fill colour along the edges it shares with
// another fragment, 1 unit wide, as the SVG's (core/write/paths.cpp measured them); in PNG the
// unit is a device pixel, as the SVG's non-scaling stroke. PDF and PostScript have no
// non-scaling strokes and cairo 1.16 no hairlines, so there the stroke is 1 pt and grows with
// the viewer's zoom: a colour boundary moves by at most half a point, where a thinner stroke
// would leave seams at 1:1. Fill::Id in PNG: no antialiasing and no stroke, the T-junctions
// made conforming (plan_fills), so each pixel centre gets exactly one fragment's id.
//
// Layers: cairo 1.16 writes no PDF optional content groups (layers) and PostScript has none;
// the lines are drawn in the SVG's order (hidden parts first, then contour, boundary, crease,
// intersection, border), each kind stroked as one path in its colour.
#include "core/write/cairo.h"

#include <cairo-pdf.h>
#include <cairo-ps.h>
#include <cairo.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/write/paths.h"
#include "core/write/shared.h"

namespace vismap {

namespace {

using detail::Q;

const char* format_name(CairoFormat f) {
  return f == CairoFormat::Pdf ? "pdf" : f == CairoFormat::Eps ? "eps" : "png";
}

cairo_status_t append(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

struct SurfaceFree {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextFree {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceFree>;
using Context = std::unique_ptr<cairo_t, ContextFree>;

void check(cairo_status_t s, CairoFormat f) {
  if (s != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string(format_name(f)) +
                             " writer: cairo: " + cairo_status_to_string(s));
}

double px(int64_t units) {
  return double(units) / double(detail::kUnit);
}

class CairoPath final : public detail::PathSink {
 public:
  explicit CairoPath(cairo_t* cr) : cr_(cr) {}
  void move(Q q) override { cairo_move_to(cr_, px(q.x), px(q.y)); }
  void line(Q q) override { cairo_line_to(cr_, px(q.x), px(q.y)); }
  void close() override { cairo_close_path(cr_); }

 private:
  cairo_t* cr_;
};

void set_rgb(cairo_t* cr, uint32_t rgb) {
  cairo_set_source_rgb(cr, double(rgb >> 16 & 0xFF) / 255.0, double(rgb >> 8 & 0xFF) / 255.0,
                       double(rgb & 0xFF) / 255.0);
}

void draw_fills(cairo_t* cr, const detail::FillPlan& plan) {
  const detail::QuantizedMap& q = plan.q;
  CairoPath sink(cr);
  cairo_set_line_width(cr, 1.0);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_BEVEL);
  for (const detail::TrianglePath& p : plan.paths) {
    set_rgb(cr, p.color);
    cairo_new_path(cr);
    for (size_t k = p.first; k < p.last; ++k) {
      const uint32_t f = plan.order[k];
      if (q.off[f + 1] > q.off[f]) detail::write_fragment(sink, q, f, plan.stroke_seams);
    }
    if (plan.stroke_seams) {
      cairo_fill_preserve(cr);
      cairo_stroke(cr);
    } else {
      cairo_fill(cr);
    }
  }
}

void draw_lines(cairo_t* cr, const LineSet& lines, const SvgStyle& style) {
  const double w = style.line_width;
  cairo_set_line_width(cr, w);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  std::vector<Q> pts;
  for (int hidden = 1; hidden >= 0; --hidden) {
    const double dash[2] = {4 * w, 3 * w};
    cairo_set_dash(cr, dash, hidden ? 2 : 0, 0);
    for (size_t k = 0; k < kLineKinds; ++k) {
      cairo_new_path(cr);
      bool any = false;
      for (size_t c = 0; c < lines.chain_count(); ++c) {
        if (size_t(lines.kind[c]) != k || lines.hidden[c] != hidden) continue;
        detail::chain_points(lines, c, pts);
        if (pts.size() < 2) continue;  // shorter than a unit: no line, as in the SVG
        any = true;
        cairo_move_to(cr, px(pts[0].x), px(pts[0].y));
        for (size_t i = 1; i < pts.size(); ++i) cairo_line_to(cr, px(pts[i].x), px(pts[i].y));
        if (lines.closed[c] && pts.size() > 2) cairo_close_path(cr);
      }
      if (!any) continue;
      set_rgb(cr, style.line_color[k]);
      cairo_stroke(cr);
    }
  }
  cairo_set_dash(cr, nullptr, 0, 0);
}

}  // namespace

std::string write_cairo(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                        const SvgStyle& style, CairoFormat format) {
  const char* name = format_name(format);
  detail::check_map(map, scene, name);
  if (style.lines && (!(style.line_width > 0) || !std::isfinite(style.line_width)))
    throw InputError(InputErrorKind::BadScene, name, "", "line width", -1,
                     "must be a positive number of pixels");
  constexpr uint32_t kMaxPng = 32767;  // cairo's image surfaces
  if (format == CairoFormat::Png && (map.width > kMaxPng || map.height > kMaxPng))
    throw InputError(InputErrorKind::TooLarge, name, "", "viewport", -1,
                     std::to_string(map.width) + "x" + std::to_string(map.height) +
                         " is over cairo's 32767 pixels a side");
  detail::FillPlan plan;
  if (style.fill) plan = detail::plan_fills(map, scene, camera, fill, name);

  std::string out;
  Surface surface;
  const double w = map.width, h = map.height;
  switch (format) {
    case CairoFormat::Pdf:
      surface.reset(cairo_pdf_surface_create_for_stream(append, &out, w, h));
      cairo_pdf_surface_set_metadata(surface.get(), CAIRO_PDF_METADATA_CREATOR, "vismap");
      break;
    case CairoFormat::Eps:
      surface.reset(cairo_ps_surface_create_for_stream(append, &out, w, h));
      cairo_ps_surface_set_eps(surface.get(), 1);
      break;
    case CairoFormat::Png:
      surface.reset(
          cairo_image_surface_create(CAIRO_FORMAT_ARGB32, int(map.width), int(map.height)));
      break;
  }
  check(cairo_surface_status(surface.get()), format);
  {
    Context cr(cairo_create(surface.get()));
    check(cairo_status(cr.get()), format);
    if (format == CairoFormat::Png && fill == Fill::Id)
      cairo_set_antialias(cr.get(), CAIRO_ANTIALIAS_NONE);
    if (style.fill) draw_fills(cr.get(), plan);
    if (style.lines) {
      // Lines are antialiased in every PNG: they are drawn, not ids.
      cairo_set_antialias(cr.get(), CAIRO_ANTIALIAS_DEFAULT);
      draw_lines(cr.get(), *style.lines, style);
    }
    check(cairo_status(cr.get()), format);
    cairo_show_page(cr.get());
  }
  if (format == CairoFormat::Png) {
    cairo_surface_flush(surface.get());
    check(cairo_surface_write_to_png_stream(surface.get(), append, &out), format);
  } else {
    cairo_surface_finish(surface.get());
    check(cairo_surface_status(surface.get()), format);
  }
  return out;
}

}  // namespace vismap
