// Implicit surfaces (issue 19, docs/IMPLICIT.md): a closed-form f(x, y, z) in MPR's s-expression
// syntax, compiled to a tape (Keeter 2020): a flat list of clauses in evaluation order, each
// naming earlier clauses, with shared subexpressions merged. The solid is f < 0.
//
// This file is the host side: the parser, the tape, and reference evaluators (plain and interval
// arithmetic) with MPR's tape shortening. The device evaluates the same tape (kernels/).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "kernels/layout.h"

namespace vismap::implicit {

// The opcodes are the device's (VM_IOP_*, kernels/layout.h): one list, named here for the host.
enum class Op : uint8_t {
  Const = VM_IOP_CONST, X = VM_IOP_X, Y = VM_IOP_Y, Z = VM_IOP_Z,  // leaves
  Add = VM_IOP_ADD, Sub = VM_IOP_SUB, Mul = VM_IOP_MUL, Div = VM_IOP_DIV,  // binary
  Min = VM_IOP_MIN, Max = VM_IOP_MAX, Pow = VM_IOP_POW,
  Neg = VM_IOP_NEG, Square = VM_IOP_SQUARE, Sqrt = VM_IOP_SQRT, Abs = VM_IOP_ABS,  // unary
  Exp = VM_IOP_EXP, Log = VM_IOP_LOG, Sin = VM_IOP_SIN, Cos = VM_IOP_COS, Tan = VM_IOP_TAN,
  Asin = VM_IOP_ASIN, Acos = VM_IOP_ACOS, Atan = VM_IOP_ATAN,
};
// is_binary and the parser's table take the leaves, binary and unary opcodes as three runs, and
// the device's VM_IOP_COPY (added by shortening, never parsed) comes after them all.
static_assert(int(Op::Const) == 0 && int(Op::Z) == 3 && int(Op::Add) == int(Op::Z) + 1 &&
                  int(Op::Neg) == int(Op::Pow) + 1 && int(Op::Atan) + 1 == VM_IOP_COPY &&
                  VM_IOP_COPY + 1 == VM_IOP_COUNT,
              "implicit::Op and kernels/layout.h's VM_IOP_* must be one contiguous list");
const char* op_name(Op op);
bool is_binary(Op op);

// One clause: its operands are earlier clauses (a, b < this clause's index); Const holds value.
struct Clause {
  Op op = Op::Const;
  uint32_t a = 0, b = 0;
  double value = 0;
};

struct Tape {
  std::vector<Clause> clauses;  // evaluation order; the last one is f
  uint32_t tree_ops = 0;        // operations in the source tree before merging (for reports)
  size_t size() const { return clauses.size(); }
  uint32_t root() const { return uint32_t(clauses.size() - 1); }
  // Clauses that are min or max: the ones tape shortening can drop a branch of.
  size_t choice_count() const;
};

// Parses an expression: numbers, x y z, (+ - * / min max a b ...), (sqrt square abs exp log sin
// cos tan asin acos atan a), (pow a b), (- a) negates. n-ary + * min max fold into balanced trees
// of binary clauses; (- a b c) is a - b - c. Shared subexpressions are merged (commutative
// operands ordered). Errors: InputError ParseError naming `file`, line and column.
// check_time (optional) is called every 4,096 tokens and throws to stop the parse (a load's
// time limit: a 64 MiB upload parses for seconds).
Tape parse(const std::string& text, const std::string& file,
           const std::function<void()>& check_time = {});
Tape load(const std::string& path);  // reads the file, then parse(); FileNotFound if it cannot

// Plain evaluation (doubles). sqrt of a negative argument is 0 (rounding in sqrt(a^2 + b^2 - r^2)
// style expressions must not make holes); log of 0 is -inf; the rest as IEEE.
double eval(const Tape& t, double x, double y, double z);

struct Interval {
  double lo = 0, hi = 0;
};
// Interval evaluation over a box: the result contains f over the whole box (each operation's
// bounds rounded outward by one ulp, so rounding never shrinks them; division by an interval
// that holds 0, and any NaN, give [-inf, inf]). When `choices` is given, it receives for every
// clause: 0 both operands may win (or not a min/max), 1 only a can, 2 only b can.
Interval eval_interval(const Tape& t, Interval x, Interval y, Interval z,
                       std::vector<uint8_t>* choices = nullptr);

// MPR's tape shortening: given the choices of eval_interval over a box, the tape with every
// decided min/max replaced by its winning operand and the clauses no longer used dropped. Over
// that box it computes f exactly as the full tape does (the same operations on the same values).
// `kept` (optional) receives, for each clause of the result, its index in `t`.
Tape shorten(const Tape& t, const std::vector<uint8_t>& choices,
             std::vector<uint32_t>* kept = nullptr);

// The tape on slots, as the device runs it (kernels/layout.h VmIClause: op, out, a, b; Const keeps
// its value's float bits in a): each clause's value goes to a slot freed by a value no longer
// needed (operands are read before out is written), so a region needs `slots` values of
// scratch, not one per clause. The device's shortened tapes keep the slots and add
// VM_IOP_COPY (out = a) for decided min/max.
struct SlotTape {
  std::vector<uint32_t> code;  // 4 words per clause
  uint32_t slots = 0, root_slot = 0;
  size_t size() const { return code.size() / 4; }
};
constexpr uint32_t kCopy = VM_IOP_COPY;
SlotTape allocate_slots(const Tape& t);
// The slot tape evaluated on the host in doubles (constants as the float the device holds).
double eval_slots(const SlotTape& t, double x, double y, double z);
// The same over `clauses` clauses of slot code (4 words each: a slot tape or one of the
// device's shortened tapes), with the gradient by forward differentiation: min/max follow the
// operand they return, sqrt/log/asin/acos/abs at the edge of their domain (or a kink) take the
// one-sided or zero derivative. Returns f; grad receives df/dx, df/dy, df/dz.
double eval_code_grad(const uint32_t* code, size_t clauses, uint32_t slots, uint32_t root_slot,
                      double x, double y, double z, double grad[3]);

// The tape with a box intersected in: max(f, lo0 - x, x - hi0, ...) over the first `dims` axes
// (2: x, y; 3: x, y, z), so the solid is f < 0 inside the box and closes at its faces.
Tape clipped_to_box(const Tape& t, const double lo[3], const double hi[3], int dims);

// The box of the solid f < 0 (lo xyz, hi xyz), for an implicit object given without bounds:
// host interval arithmetic over a cube [-s, s]^3, every box not shown empty (f >= 0) split in
// eight with its tape shortened, level by level, until a box's side is at most 1/64 of the
// extent found; the boxes not shown empty, grown by one box. s = 16, 32, ... up to `search`:
// the first cube that holds some of the solid and whose faces the solid does not reach (interval
// bounds are loose over large far boxes, so a cube near the object's size proves it bounded where
// the largest cannot); a part of the solid outside that cube is not in the box (give bounds to
// choose it). Errors name `file`: InputError BadScene when the solid reaches the faces of [-search,
// search]^3 (unbounded, or larger: give bounds), EmptyMesh when f >= 0 over the whole cube,
// TooLarge past 2^20 boxes or past `limits.max_bytes`.
struct SearchLimits {
  // Bytes of shortened tapes one level of the search may hold (the level before it holds at most
  // as many): 0 or above 256 MiB: 256 MiB. A load passes what its byte budget has left.
  uint64_t max_bytes = 0;
  // Called for every box; throws to stop the search (a load's time limit). May be empty.
  std::function<void()> check_time;
};
std::array<double, 6> find_bounds(const Tape& t, const std::string& file, double search = 1024,
                                  const SearchLimits& limits = {});

}  // namespace vismap::implicit
