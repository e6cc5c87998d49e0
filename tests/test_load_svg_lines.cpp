// read_svg_lines (core/lines/svg_lines.h): the SVG drawings `vismap check --lines-from` scores, on
// tiny hand-written files in the forms the peers write (docs/LINES.md, "Against other tools").
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/lines/svg_lines.h"

namespace vismap {
namespace {

std::vector<double> chain(const LineSet& l, size_t c) {
  return {l.xy.begin() + 2 * l.off[c], l.xy.begin() + 2 * l.off[c + 1]};
}

TEST(SvgLines, FreestyleFormAbsolutePairsAndLinesetKinds) {
  // Freestyle's exporter: no viewBox, "M x, y x, y ..." pairs, lineset groups LAYER_LINESET.
  const std::string svg = R"svg(<?xml version="1.0" encoding="ascii" standalone="no"?>
<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" "http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">
<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="64" height="32">
  <g xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" id="ViewLayer_contour" inkscape:groupmode="lineset">
    <g id="strokes"><path fill="none" d=" M 1.000, 2.000 3.500, 2.000 3.500, 10.000 " /></g>
  </g>
  <g id="ViewLayer_crease"><path d="M 0,0 L 5 5" /></g>
</svg>)svg";
  const LineSet l = read_svg_lines(svg, "f.svg", 64, 32);
  ASSERT_EQ(l.chain_count(), 2u);
  EXPECT_EQ(chain(l, 0), (std::vector<double>{1, 2, 3.5, 2, 3.5, 10}));
  EXPECT_EQ(l.kind[0], LineKind::Contour);
  EXPECT_EQ(l.kind[1], LineKind::Crease);
  EXPECT_FALSE(l.closed[0]);
}

TEST(SvgLines, OurCompactRelativeFormClosedAndHiddenLeftOut) {
  // Our writer: relative m/l with the shortest separators ("1.5-2", ".5.5"), z, class groups,
  // hidden parts in class="hidden" (left out: the check scores the visible drawing).
  const std::string svg = R"svg(<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10" width="10" height="10">
<style>path{vector-effect:non-scaling-stroke}</style>
<g class="lines" fill="none"><g class="hidden" stroke-dasharray="4 3"><g class="contour"><path d="M1 1l8 0"/></g></g>
<g class="boundary"><path d="M1 1l1.5-.5.5.5h1v2z"/></g>
<g class="intersection"><polyline points="0,0 1,1 2,0"/><line x1="1" y1="2" x2="3" y2="4"/></g></g>
</svg>)svg";
  const LineSet l = read_svg_lines(svg, "ours.svg", 10, 10);
  ASSERT_EQ(l.chain_count(), 3u);
  EXPECT_EQ(l.kind[0], LineKind::Boundary);
  EXPECT_TRUE(l.closed[0]);
  EXPECT_EQ(chain(l, 0), (std::vector<double>{1, 1, 2.5, 0.5, 3, 1, 4, 1, 4, 3}));
  EXPECT_EQ(l.kind[1], LineKind::Intersection);
  EXPECT_EQ(chain(l, 1), (std::vector<double>{0, 0, 1, 1, 2, 0}));
  EXPECT_EQ(chain(l, 2), (std::vector<double>{1, 2, 3, 4}));
}

TEST(SvgLines, TransformsOnGroupsCompose) {
  const std::string svg = R"svg(<svg width="100" height="100"><g transform="translate(10,20)">
<g transform="scale(2)"><path d="M1 1L2 3"/></g></g><g transform="matrix(1 0 0 -1 0 100)"><path d="M0 0 V 10"/></g></svg>)svg";
  const LineSet l = read_svg_lines(svg, "t.svg", 100, 100);
  ASSERT_EQ(l.chain_count(), 2u);
  EXPECT_EQ(chain(l, 0), (std::vector<double>{12, 22, 14, 26}));
  EXPECT_EQ(chain(l, 1), (std::vector<double>{0, 100, 0, 90}));
}

TEST(SvgLines, RefusesWhatItDoesNotReadNamingFileAndElement) {
  try {
    read_svg_lines(R"svg(<svg width="8" height="8"><g><rect x="0" y="0" width="1" height="1"/></g></svg>)svg",
                   "r.svg", 8, 8);
    FAIL() << "a rect was read";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "r.svg");
    EXPECT_EQ(e.element(), "element <rect>");
    EXPECT_EQ(e.index(), 2);
  }
  EXPECT_THROW(read_svg_lines(R"svg(<svg width="8" height="8"><path d="M0 0C1 1 2 2 3 3"/></svg>)svg",
                              "c.svg", 8, 8),
               InputError);
  EXPECT_THROW(read_svg_lines(R"svg(<svg width="8" height="8"><g transform="skewX(3)"><path d="M0 0L1 1"/></g></svg>)svg",
                              "s.svg", 8, 8),
               InputError);
  EXPECT_THROW(read_svg_lines(R"svg(<svg width="8" height="8"><path d="M0 0L1 1"/>)svg", "u.svg", 8, 8),
               InputError);
}

TEST(SvgLines, SizeMustBeTheCamerasEitherWay) {
  const std::string a = R"svg(<svg viewBox="0 0 64 48"><path d="M0 0L1 1"/></svg>)svg";
  EXPECT_NO_THROW(read_svg_lines(a, "a.svg", 64, 48));
  EXPECT_THROW(read_svg_lines(a, "a.svg", 48, 64), InputError);
  const std::string b = R"svg(<svg width="64px" height="48"><path d="M0 0L1 1"/></svg>)svg";
  EXPECT_NO_THROW(read_svg_lines(b, "b.svg", 64, 48));
  EXPECT_THROW(read_svg_lines(b, "b.svg", 64, 47), InputError);
}

}  // namespace
}  // namespace vismap
