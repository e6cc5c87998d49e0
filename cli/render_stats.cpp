// What `vismap render --stats` prints on stderr: the device and the per-stage table, the dicing,
// the frame's counts, the output and its lines, and the times.
#include <cstdio>

#include "cli/render.h"

namespace vismap::cli {

namespace {

// The device and the per-stage table.
void print_stage_table(const RenderReport& r) {
  const RenderStats& st = r.frame.rendered.stats;
  std::fprintf(stderr, "device: %s / %s\n", r.device.platform.c_str(), r.device.name.c_str());
  std::fprintf(stderr, "%-12s %10s %9s %6s %10s %12s %12s\n", "stage", "ms", "launches", "reads",
               "MB moved", "in", "out");
  double sum = 0;
  for (const StageStat& s : st.stages) {
    std::fprintf(stderr, "%-12s %10.2f %9u %6u %10.2f %12llu %12llu\n", s.name.c_str(), s.ms,
                 s.launches, s.host_syncs, (s.device_bytes + s.transfer_bytes) / 1e6,
                 static_cast<unsigned long long>(s.items_in),
                 static_cast<unsigned long long>(s.items_out));
    sum += s.ms;
  }
  std::fprintf(stderr,
               "%-12s %10.2f   (sum of stage times; pipeline wall %.2f ms, upload %.2f ms)\n",
               "kernels", sum, st.pipeline_ms, st.upload_ms);
}

// Dicing before the frame: patches, Loop surfaces, implicit objects.
void print_surface_stats(const RenderReport& r) {
  const TessellateStats& ts = r.frame.rendered.dice;
  if (ts.triangles)
    std::fprintf(stderr,
                 "tessellate: %.2f ms, %u launches, %u reads, %u split rounds, %llu pieces "
                 "(%llu culled, %llu short of the tolerance at the largest rate), %llu "
                 "triangles, Loop level %u\n",
                 ts.ms, ts.launches, ts.host_syncs, ts.split_rounds,
                 static_cast<unsigned long long>(ts.pieces),
                 static_cast<unsigned long long>(ts.culled),
                 static_cast<unsigned long long>(ts.over_rate),
                 static_cast<unsigned long long>(ts.triangles), ts.subdivision_level);
  if (ts.implicit_leaves)
    std::fprintf(stderr,
                 "implicit: %llu cells per axis, %llu leaf cells, clauses per "
                 "leaf %.1f of %llu (tape shortening), %llu regions hidden behind full boxes "
                 "and %llu back faces left out; ms: queue %.1f, corners %.1f, mesh %.1f\n",
                 static_cast<unsigned long long>(ts.implicit_cells),
                 static_cast<unsigned long long>(ts.implicit_leaves),
                 double(ts.implicit_leaf_clauses) / double(ts.implicit_leaves),
                 static_cast<unsigned long long>(ts.implicit_clauses_full),
                 static_cast<unsigned long long>(ts.implicit_occluded),
                 static_cast<unsigned long long>(ts.implicit_back_faces), ts.implicit_queue_ms,
                 ts.implicit_points_ms, ts.implicit_mesh_ms);
}

// The frame's counts, syncs, memory and buckets.
void print_frame_stats(const RenderReport& r) {
  const RenderStats& st = r.frame.rendered.stats;
  std::fprintf(stderr,
               "input triangles %llu (dropped degenerate %llu), screen triangles %llu, "
               "silhouette edges %llu\n",
               static_cast<unsigned long long>(st.input_triangles),
               static_cast<unsigned long long>(r.dropped_degenerate),
               static_cast<unsigned long long>(st.screen_triangles),
               static_cast<unsigned long long>(st.silhouette_edges));
  std::fprintf(stderr,
               "fragments %llu, visible %llu, clip rounds %u, host syncs %u, device memory peak "
               "%.1f MB (%.1f MB allocated in all)\n",
               static_cast<unsigned long long>(st.fragments),
               static_cast<unsigned long long>(st.visible_fragments), st.clip_rounds,
               st.host_syncs, st.peak_device_bytes / 1e6, st.allocated_device_bytes / 1e6);
  std::fprintf(stderr,
               "per frame: launches %u, blocking reads %u, bytes moved %.2f MB (device model "
               "%.2f MB, host<->device %.3f MB); modelled GPU floor %.3f ms (pipeline wall "
               "here %.2f ms)\n",
               st.launches, st.host_syncs, (st.device_bytes + st.transfer_bytes) / 1e6,
               st.device_bytes / 1e6, st.transfer_bytes / 1e6, modelled_gpu_floor_ms(st),
               st.pipeline_ms);
  std::fprintf(
      stderr,
      "entangled pairs %llu, crossing entries %llu, thin fragments %llu, deep tournaments %llu\n",
      static_cast<unsigned long long>(st.entangled_pairs),
      static_cast<unsigned long long>(st.crossing_lines),
      static_cast<unsigned long long>(st.thin_fragments),
      static_cast<unsigned long long>(st.deep_tournaments));
  std::fprintf(stderr,
               "left out: %llu back faces (closed meshes seen from outside); as provably hidden, "
               "%llu screen triangles (cull), %llu candidate edges (the triangle hidden along "
               "them), %llu fragments (stopped in the clip rounds)%s\n",
               static_cast<unsigned long long>(st.back_faces),
               static_cast<unsigned long long>(st.culled_triangles),
               static_cast<unsigned long long>(st.pruned_candidates),
               static_cast<unsigned long long>(st.dropped_fragments),
               r.args.cull ? "" : "; culling off (--no-cull)");
  if (st.entangled_pairs == 0)
    std::fprintf(stderr,
                 "skipped: the crossing lines' sorting and entries (no entangled pair)\n");
  if (st.apart_need > 0)
    std::fprintf(stderr,
                 "skipped: the crossing search between triangles farther apart in 3D than %.3g "
                 "that share no vertex (scene facts: %llu of %llu triangles at their cap, found "
                 "in %.1f ms)\n",
                 st.apart_need, static_cast<unsigned long long>(st.facts_isolated),
                 static_cast<unsigned long long>(st.input_triangles), st.facts_ms);
  else if (st.has_facts)
    std::fprintf(stderr, "scene facts found (%.1f ms) but not used: in this view fewer than "
                 "half the triangles are apart (it blurs more than their clearances), or it is "
                 "orthographic\n", st.facts_ms);
  if (r.args.memory_budget)
    std::fprintf(stderr,
                 "memory budget %.1f MB: %u bucket(s), each planned under %.1f MB of work\n",
                 r.args.memory_budget / 1e6, st.buckets, st.bucket_work_bytes / 1e6);
}

// The output file, and what the compact encoder and the line extraction made.
void print_output_stats(const RenderReport& r) {
  const PlanarMap& map = r.frame.rendered.map;
  const CompactStats& cs = r.frame.encoded.compact;
  const LineSet* lines = r.frame.lines ? &*r.frame.lines : nullptr;
  // Each fragment (a convex polygon of n vertices) is n - 2 triangles.
  const size_t triangles = map.vertex_count() - 2 * map.fragment_count();
  std::fprintf(stderr, "output: %zu triangles in %zu fragments, %zu bytes (%s)\n", triangles,
               map.fragment_count(), r.frame.encoded.bytes.size(), frame::format_row(r.args.output.format).name);
  if (r.args.output.format == frame::OutputFormat::Compact)
    std::fprintf(stderr,
                 "compact: %llu vertices, %llu triangles (%llu T-junctions inserted, %llu "
                 "dropped on the grid), before zstd: vertices %llu, indices %llu, ids %llu, "
                 "shades %llu bytes\n",
                 static_cast<unsigned long long>(cs.vertices),
                 static_cast<unsigned long long>(cs.triangles),
                 static_cast<unsigned long long>(cs.t_junctions),
                 static_cast<unsigned long long>(cs.dropped),
                 static_cast<unsigned long long>(cs.vertex_bytes),
                 static_cast<unsigned long long>(cs.index_bytes),
                 static_cast<unsigned long long>(cs.id_bytes),
                 static_cast<unsigned long long>(cs.shade_bytes));
  if (lines) {
    std::fprintf(stderr, "lines: %zu chains;", lines->chain_count());
    for (size_t k = 0; k < kLineKinds; ++k)
      std::fprintf(stderr, " %s %llu", line_kind_name(LineKind(k)),
                   static_cast<unsigned long long>(lines->edges[k]));
    std::fprintf(stderr, " map edges;");
    if (r.args.output.lines.hidden)
      for (size_t k = 0; k < kLineKinds; ++k)
        std::fprintf(stderr, " hidden %s %llu", line_kind_name(LineKind(k)),
                     static_cast<unsigned long long>(lines->hidden_edges[k]));
    std::fprintf(stderr, " %.1f ms\n", r.frame.lines_ms);
  }
}

}  // namespace

void print_render_stats(const RenderReport& r) {
  print_stage_table(r);
  print_surface_stats(r);
  print_frame_stats(r);
  print_output_stats(r);
  const frame::Frame& f = r.frame;
  std::fprintf(stderr,
               "time: load %.1f ms, dice %.1f ms, render %.1f ms, lines %.1f ms, encode %.1f ms, "
               "total %.1f ms\n",
               r.load_ms, f.rendered.dice_ms, f.rendered.render_ms, f.lines_ms, f.encode_ms,
               r.total_ms);
}


void print_implicit_2d_stats(const DeviceInfo& device, const implicit::Tape& tape,
                             const frame::Frame2D& f, double load_ms, double device_ms) {
  const implicit::Regions2D& r = f.regions;
  size_t points = 0;
  for (const auto& l : r.loops) points += l.size();
  std::fprintf(stderr, "device: %s / %s\n", device.platform.c_str(), device.name.c_str());
  std::fprintf(stderr,
               "implicit 2D: %zu clauses, cell %.3f px, %llu leaves, %llu full cells, %zu "
               "loops (%zu points), %zu regions\n",
               tape.size(), r.cell_px, static_cast<unsigned long long>(r.leaves),
               static_cast<unsigned long long>(r.full_cells), r.loops.size(), points,
               r.regions.size());
  std::fprintf(stderr, "clauses evaluated per round:");
  for (uint64_t c : r.clauses_per_round)
    std::fprintf(stderr, " %llu", static_cast<unsigned long long>(c));
  std::fprintf(stderr,
               "\nms: load+parse %.2f, device start %.2f, queue %.2f, contour %.2f, svg %.2f "
               "(a first run also builds the kernels, inside queue)\n",
               load_ms, device_ms, r.queue_ms, r.contour_ms, f.svg_ms);
}

}  // namespace vismap::cli
