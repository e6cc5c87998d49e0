// Screen indices: the cells of screen triangles covering a point, and the crossing lines the
// pipeline clipped penetrating pairs with, by source pair.
#include <algorithm>
#include <cmath>

#include "core/lines/classifier.h"

namespace vismap::lines_detail {

void Classifier::build_cells() {
  cells_x_ = std::max(1, int(std::ceil(map_.width / kCell)));
  cells_y_ = std::max(1, int(std::ceil(map_.height / kCell)));
  const double g = st_.grid_scale;
  auto range = [&](uint32_t s, int& x0, int& y0, int& x1, int& y1) {
    const int32_t* v = &st_.xy[6 * size_t(s)];
    const double lx = std::min({v[0], v[2], v[4]}) / g, hx = std::max({v[0], v[2], v[4]}) / g;
    const double ly = std::min({v[1], v[3], v[5]}) / g, hy = std::max({v[1], v[3], v[5]}) / g;
    const double m = kSeamPx;
    x0 = std::clamp(int(std::floor((lx - m) / kCell)), 0, cells_x_ - 1);
    x1 = std::clamp(int(std::floor((hx + m) / kCell)), 0, cells_x_ - 1);
    y0 = std::clamp(int(std::floor((ly - m) / kCell)), 0, cells_y_ - 1);
    y1 = std::clamp(int(std::floor((hy + m) / kCell)), 0, cells_y_ - 1);
  };
  cell_start_.assign(size_t(cells_x_) * cells_y_ + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<uint32_t> fill;
    if (pass) {
      for (size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
      fill.assign(cell_start_.begin(), cell_start_.end() - 1);
      cell_tris_.resize(cell_start_.back());
    }
    for (uint32_t s = 0; s < st_.size(); ++s) {
      int x0, y0, x1, y1;
      range(s, x0, y0, x1, y1);
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const size_t c = size_t(y) * cells_x_ + x;
          if (pass)
            cell_tris_[fill[c]++] = s;
          else
            ++cell_start_[c + 1];
        }
    }
  }
}

// --- Crossings: the lines the pipeline clipped penetrating pairs with. ---
void Classifier::index_crossings() {
  const auto& X = st_.crossings;
  crossing_next_.assign(X.size(), kNone);
  for (uint32_t i = 0; i < X.size(); ++i) {
    const uint32_t* s0 = by_source_.find(pair_key(X[i].mesh[0], X[i].triangle[0]));
    const uint32_t* s1 = by_source_.find(pair_key(X[i].mesh[1], X[i].triangle[1]));
    if (!s0 || !s1) bad("a crossing names a triangle with no screen triangle");
    auto [first, fresh] = crossing_.emplace(pair_key(std::min(*s0, *s1), std::max(*s0, *s1)), i);
    if (!fresh) {
      crossing_next_[i] = crossing_next_[first];
      crossing_next_[first] = i;
    }
  }
}

// Does the map edge a-b lie on a crossing line of the sources of screen triangles s1, s2?
// (A source pair split into several screen triangles, by the view volume's planes, has a
// line for each piece, snapped alike but not exactly one: where two pieces meet, a map edge
// a rounding long may join the two lines, an end on each.)
bool Classifier::on_crossing(uint32_t s1, uint32_t s2, const double* a, const double* b) const {
  const uint32_t f1 = *by_source_.find(pair_key(st_.mesh[s1], st_.triangle[s1]));
  const uint32_t f2 = *by_source_.find(pair_key(st_.mesh[s2], st_.triangle[s2]));
  const uint32_t* first = crossing_.find(pair_key(std::min(f1, f2), std::max(f1, f2)));
  const double g = st_.grid_scale, tol = kOnCrossing * g;
  bool on_a = false, on_b = false;
  for (uint32_t i = first ? *first : kNone; i != kNone; i = crossing_next_[i]) {
    const ScreenTriangles::Crossing& c = st_.crossings[i];
    const long double A = c.a, B = c.b, C = c.c, n = std::hypot(double(c.a), double(c.b));
    auto on = [&](const double* p) {
      return n > 0 &&
             double(std::abs(A * (long double)(p[0] * g) + B * (long double)(p[1] * g) + C)) <=
                 tol * n;
    };
    on_a |= on(a);
    on_b |= on(b);
  }
  return on_a && on_b;
}

}  // namespace vismap::lines_detail
