/* Buffer layouts shared by the host (C++) and the kernels (OpenCL C). One truth: both sides
 * include this file; the host static_asserts sizes and offsets. Fixed-width types only. */
#ifndef VISMAP_KERNELS_LAYOUT_H
#define VISMAP_KERNELS_LAYOUT_H

#ifdef __OPENCL_VERSION__
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef int vm_i32;
typedef uint vm_u32;
typedef long vm_i64;
typedef ulong vm_u64;
#else
#include <cstddef>
#include <cstdint>
typedef int32_t vm_i32;
typedef uint32_t vm_u32;
typedef int64_t vm_i64;
typedef uint64_t vm_u64;
#endif

/* Grid units per pixel: every 2D decision works on integer coordinates of this grid. */
#define VM_GRID_SCALE 256
/* Largest viewport side in pixels; grid coordinates stay below 2^22 (docs/NUMERICS.md). */
#define VM_MAX_VIEWPORT 16384
/* Interior sample points carry this many extra fraction bits below the grid. */
#ifndef VM_POINT_BITS
#define VM_POINT_BITS 24
#endif
/* Relative depth difference under which two surfaces tie (the fixed tie rule decides). */
#define VM_TIE_EPS 1e-6

/* A pair of screen triangles' relation (crossings.cl: pair_relation; the host reads it back). */
#define VM_REL_NONE 0    /* footprints do not overlap with positive area */
#define VM_REL_A_FRONT 1 /* a is in front of b over the whole overlap */
#define VM_REL_B_FRONT 2
#define VM_REL_CROSS 3
#define VM_REL_TIE 4 /* or'ed in: decided by the tie rule (the planes agree within the band) */

/* Per-mesh cull mode (host decides; only closed meshes seen from outside are culled). */
#define VM_CULL_NONE 0
#define VM_CULL_POSITIVE 1 /* drop triangles whose snapped grid orientation is > 0 */
#define VM_CULL_NEGATIVE 2 /* drop triangles whose snapped grid orientation is < 0 */

/* A triangle after transform, clipping, culling and snapping. Vertices are on the grid (y down)
 * and ordered so that orient(v0, v1, v2) > 0. q is the nearness (1/w for perspective, -z_ndc
 * for orthographic): larger is closer and it is affine on the screen. After snap_depth_planes,
 * plane_k = k means q[i] = N_i / 2^k with N_i = A (x_i - x_0) + B (y_i - y_0) + N_0 for integers
 * |A|, |B| <= 2^VM_PLANE_SLOPE_BITS and |N_i| <= 2^VM_PLANE_VALUE_BITS: the depth plane is an
 * integer plane over 2^k, so the crossing line of two such triangles is exact (crossings.cl).
 * VM_PLANE_FREE: the plane could not be snapped within that budget; q is as transformed. */
typedef struct {
  vm_i32 x[3];
  vm_i32 y[3];
  vm_u32 mesh;
  vm_u32 tri; /* source triangle within its mesh */
  double q[3];
  vm_u32 src; /* global input triangle index (row in the uploaded index buffer) */
  vm_i32 plane_k;
} VmScreenTri;

/* Depth planes snapped to integers over 2^k (docs/NUMERICS.md §2 "Depth planes"). */
#define VM_PLANE_FREE (-0x7fffffff)
#define VM_PLANE_SLOPE_BITS 29
#define VM_PLANE_VALUE_BITS 52
/* Relative depth error the frame's k aims at: 2^-VM_PLANE_FIDELITY_BITS of max |q| per triangle. */
#define VM_PLANE_FIDELITY_BITS 24

/* A silhouette edge: a segment between two grid points with the nearness at each end. */
typedef struct {
  vm_i32 x0, y0, x1, y1;
  double q0, q1;
} VmEdge;

/* A directed line a*x + b*y + c = 0 on the grid; a fragment's interior is on its positive side.
 * An edge's line goes through two grid points (|a|, |b| <= 2^23, |c| <= 2^46); a crossing line
 * is exact between two snapped depth planes (|a|, |b| <= 2^30, |c| <= 2^54), else the true
 * intersection line rounded to integers (max(|a|, |b|) <= 2^23, |c| <= 2^47). */
typedef struct {
  vm_i32 a, b;
  vm_i64 c;
} VmLine;

/* Per fragment in the clip work queue: the screen triangle it came from, its line count, the
 * next candidate edge to look at. Lines are stored in a parallel buffer, VM_MAXL per fragment. */
typedef struct {
  vm_u32 tri;
  vm_u32 nlines;
  vm_u32 next;
  vm_u32 pad;
} VmFragMeta;

/* The bin grid: uniform tiles of tile_size = 2^tile_shift grid units. */
typedef struct {
  vm_i32 tile_size;
  vm_i32 tiles_x;
  vm_i32 tiles_y;
  vm_i32 tile_shift;
} VmGrid;

/* Supporting lines per fragment: the program is built with -DVM_MAXL=<n> by the host
 * (ClRuntime::build), which doubles it and runs the clipping again when a fragment needs more. */
#ifndef VM_MAXL
#define VM_MAXL 16
#endif

/* The frame's totals buffer: a few words every stage may raise or count into, read back by the
 * host (one small read per clip round brings all of them). */
#define VM_TOTAL_STATUS 0  /* VM_STATUS_* flags */
#define VM_TOTAL_SLIVERS 1 /* fragments without interior, dropped (occlusion.cl occlude_thin) */
#define VM_TOTAL_NEXT 2    /* the next clip round's queue length (clip.cl, scan_to) */
#define VM_TOTAL_DONE 3    /* fragments a clip round finished (scan_to) */
#define VM_TOTAL_THIN 4    /* fragments thinner than the fine sample grid (occlusion.cl occlude) */
#define VM_TOTAL_DEEP 5    /* tournaments of more than VM_TOUR_MAX triangles (occlude_deep) */
#define VM_TOTAL_DROPPED 6 /* fragments the clip rounds proved hidden and dropped (cull.cl) */
/* The counts of the stages before the clip rounds, last: a rerun of the clipping (more lines a
 * fragment) zeroes the words before them only. */
#define VM_TOTAL_PRUNED 7 /* candidate edges along which the triangle is proven hidden (candidates.cl) */
#define VM_TOTAL_CULLED 8 /* screen triangles proven hidden before the crossings (cull.cl) */
#define VM_TOTAL_SLOTS 9

/* The frame's words (transform.cl; zeroed by transform_vertices): four depth-exponent
 * reductions, then counts summed over the frame's regions. */
#define VM_FRAME_BACK_FACES 4 /* back faces of closed meshes left out (clip_count) */
#define VM_FRAME_WORDS 5

/* The silhouette hash's view of an edge (silhouettes.cl edge_classify), for the cull and the
 * kept triangles' silhouettes: its partner, the other edge of its key, or VM_EDGE_ONE (a boundary)
 * or VM_EDGE_MANY (three or more share it); key_sil 0 or 1 (its key is a silhouette), or
 * VM_KEY_SIL_MANY: shared three or more times, partners holding the hash slot whose flags word
 * has VM_SIDE_LEFT / VM_SIDE_RIGHT or'ed in by each edge for the side of the key its triangle is
 * on (the cull counts such a key as covered on both sides when both bits are set). */
#define VM_EDGE_ONE 0xffffffffu
#define VM_EDGE_MANY 0xfffffffeu
#define VM_KEY_SIL_MANY 2
#define VM_SIDE_LEFT 2u
#define VM_SIDE_RIGHT 4u

/* Status flags a kernel can raise in totals[VM_TOTAL_STATUS] (read back by the host). */
#define VM_STATUS_LINES_OVERFLOW 1u
#define VM_STATUS_HASH_FULL 2u
#define VM_STATUS_PAIRS_OVERFLOW 4u

/* The clip passes' queue state on the device (clip.cl), so that several passes run per
 * read-back: two copies of VM_CLIP_WORDS words; pass p reads copy p % 2 and its clip_apply writes
 * the other. STOP: 0 while running, else the VM_CLIP_STOP_* reason the passes stopped at (the
 * queue is left as it was, for the host to grow the lists and go on). */
#define VM_CLIP_NQ 0     /* fragments in the queue */
#define VM_CLIP_DONE 1   /* finished fragments so far (the finished list's length) */
#define VM_CLIP_STOP 2   /* 0, or why the passes stopped */
#define VM_CLIP_ROUNDS 3 /* rounds (levels of splits) that ran on fragments since the host set it */
#define VM_CLIP_PASSES 4 /* passes that ran on a non-empty queue (each swaps the queue's buffers) */
#define VM_CLIP_WORDS 8
/* A pass runs up to VM_CLIP_LEVELS rounds, the children of all but the last kept in private
 * memory (clip.cl clip_walk): each item records the cuts of a binary tree of VM_CLIP_NODES nodes
 * and counts VM_CLIP_COUNTS numbers (the last level's children, each level's finished). */
#define VM_CLIP_LEVELS 3
#define VM_CLIP_NODES ((1 << VM_CLIP_LEVELS) - 1)
#define VM_CLIP_COUNTS (VM_CLIP_LEVELS + 1)
#define VM_CLIP_STOP_QUEUE 1u /* the children did not fit the next pass's grid */
#define VM_CLIP_STOP_DONE 2u  /* the finished fragments did not fit the finished list */
/* A pass over at most VM_CLIP_FUSED_MAX items is two launches: clip_find scans each group's
 * counts, clip_apply sums the groups' totals (at most 16 loads an item); above, the counts are
 * scanned between them. */
#define VM_CLIP_FUSED_MAX (4096u * VM_SCAN_WG)
#define VM_CLIP_STOP_LINES 3u /* a child needs more than VM_MAXL lines (VM_STATUS_LINES_OVERFLOW) */

/* Crossing pairs a screen triangle keeps in its inline scratch slots in the first traversal
 * (crossings.cl cross_pairs); a triangle with more traverses again into exact space. */
#define VM_PAIRS_INLINE 4

/* The exclusive scan (scan.cl): VM_SCAN_WG work-items per group, VM_SCAN_PER_ITEM counts each. */
#define VM_SCAN_WG 256
#define VM_SCAN_PER_ITEM 8
#define VM_SCAN_BLOCK (VM_SCAN_WG * VM_SCAN_PER_ITEM)
/* Blocks up to which scan_finish adds the block sums in the second launch (each group sums the
 * ones before it: at most 16 loads an item); above, they are scanned recursively. */
#define VM_SCAN_FINISH_MAX 4096
/* Counts up to which one work-group scans them alone in one launch (scan_small: 64 an item). */
#define VM_SCAN_SMALL_MAX (VM_SCAN_WG * 64)

/* Implicit surfaces (issue 19, implicit.cl): a tape clause on slots. The opcodes are listed here
 * only; implicit::Op (core/implicit/implicit.h) names them for the host and static_asserts that
 * they run contiguously (VM_IOP_COPY is added by shortening: out = a). Const keeps its float's
 * bits in a. Operands are read before out is written, so out may reuse an operand's slot. */
#define VM_IOP_CONST 0
#define VM_IOP_X 1
#define VM_IOP_Y 2
#define VM_IOP_Z 3
#define VM_IOP_ADD 4
#define VM_IOP_SUB 5
#define VM_IOP_MUL 6
#define VM_IOP_DIV 7
#define VM_IOP_MIN 8
#define VM_IOP_MAX 9
#define VM_IOP_POW 10
#define VM_IOP_NEG 11
#define VM_IOP_SQUARE 12
#define VM_IOP_SQRT 13
#define VM_IOP_ABS 14
#define VM_IOP_EXP 15
#define VM_IOP_LOG 16
#define VM_IOP_SIN 17
#define VM_IOP_COS 18
#define VM_IOP_TAN 19
#define VM_IOP_ASIN 20
#define VM_IOP_ACOS 21
#define VM_IOP_ATAN 22
#define VM_IOP_COPY 23
#define VM_IOP_COUNT 24
typedef struct {
  vm_u32 op, out, a, b;
} VmIClause;
/* A region of the implicit queue: the box [lo, lo + size] (z unused in 2D) and its tape, a slice
 * of the round's tape pool. */
typedef struct {
  float lo[3];
  float size;
  vm_u32 tape_off, tape_len;
  vm_u32 pad[2];
} VmIRegion;
/* The view a 3D queue sizes its leaves by (docs/IMPLICIT.md "3D"): depth(p) = depth[0..2] . p +
 * depth[3] is the view depth of a point of the object's space; a region becomes a leaf once its
 * side is at most c0 + c1 * max(near_d, d), d the least depth over the region grown by its side
 * on every side. c0 = c1 = 0 (2D, a coarse pass): leaves only in the last round. A region is
 * culled outside a view plane only beyond margin plus twice that side at its farthest depth. */
typedef struct {
  float depth[4];
  float c0, c1, near_d, margin;
} VmIView;
/* A 3D queue's occlusion (docs/IMPLICIT.md "Hidden regions"): a depth image of width x height
 * texels over the viewport, each the least, over the full boxes covering the whole texel, of the
 * box's greatest entry depth at the texel's corners. Object-space point p maps to texel
 * coordinates (x / w, y / w), x = proj[0..3] . (p, 1), y = proj[4..7] . (p, 1), w = proj[8..11] .
 * (p, 1) (the view depth); the ray through texel coordinates (tx, ty) is eye + t d, d = dir[0..2]
 * + tx dir[4..6] + ty dir[8..10], at view depth t. */
typedef struct {
  float proj[12];
  float eye[4];
  float dir[12];
  vm_u32 width, height;
  float dmax, pad; /* the largest |d| component over the viewport */
} VmIOcclusion;
/* The queue's totals per round: regions found full (f < 0 over the box) and empty (f >= 0),
 * regions culled outside the view, leaves of the last round larger than their depth allows,
 * regions hidden behind full boxes; then the four scans' totals (the split regions' tape clauses
 * and count, the leaves' likewise). */
#define VM_ITOTAL_FULL 0
#define VM_ITOTAL_EMPTY 1
#define VM_ITOTAL_CULLED 2
#define VM_ITOTAL_COARSE 3
#define VM_ITOTAL_OCCLUDED 4
#define VM_ITOTAL_POOL 5
#define VM_ITOTAL_SPLIT 6
#define VM_ITOTAL_LEAF_POOL 7
#define VM_ITOTAL_LEAVES 8
#define VM_ITOTAL_SLOTS 9

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VmIClause) == 16, "VmIClause layout");
static_assert(sizeof(VmIRegion) == 32 && offsetof(VmIRegion, tape_off) == 16, "VmIRegion layout");
static_assert(sizeof(VmIView) == 32 && offsetof(VmIView, c0) == 16, "VmIView layout");
static_assert(sizeof(VmIOcclusion) == 128 && offsetof(VmIOcclusion, width) == 112,
              "VmIOcclusion layout");
static_assert(sizeof(VmScreenTri) == 64, "VmScreenTri layout");
static_assert(offsetof(VmScreenTri, q) == 32, "VmScreenTri.q offset");
static_assert(sizeof(VmEdge) == 32, "VmEdge layout");
static_assert(sizeof(VmLine) == 16, "VmLine layout");
static_assert(sizeof(VmFragMeta) == 16, "VmFragMeta layout");
static_assert(sizeof(VmGrid) == 16, "VmGrid layout");
/* The host reads the totals as VM_TOTAL_SLOTS words, launches scan_blocks with VM_SCAN_WG items
 * a group (its reqd_work_group_size) and VM_SCAN_BLOCK counts a group, and sizes the pair
 * scratch by VM_PAIRS_INLINE. */
static_assert(VM_TOTAL_STATUS == 0 && VM_TOTAL_SLOTS == 9 && VM_TOTAL_PRUNED == 7 &&
                  VM_TOTAL_CULLED == 8,
              "totals slots 0..8, the counts before the clip rounds last (a rerun zeroes the rest)");
static_assert(VM_TOTAL_DEEP == VM_TOTAL_THIN + 1, "occlusion reads thin and deep in one read");
static_assert(VM_SCAN_BLOCK == VM_SCAN_WG * VM_SCAN_PER_ITEM &&
                  (VM_SCAN_WG & (VM_SCAN_WG - 1)) == 0,
              "scan blocks of a power-of-two work-group");
static_assert(VM_PAIRS_INLINE >= 1, "inline pair slots");
static_assert(VM_CLIP_PASSES < VM_CLIP_WORDS, "clip state words");
static_assert(VM_CLIP_COUNTS == 4, "clip.cl packs and sums a pass's counts as four words");
#endif

#endif
