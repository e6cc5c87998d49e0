#include "core/implicit/implicit.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <unordered_map>

#include "core/error.h"
#include "core/util/format.h"

namespace vismap::implicit {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct OpInfo {
  const char* name;
  Op op;
  int arity;  // 1 unary, 2 binary (pow), -1 n-ary (>= 1), -2 n-ary (>= 2: / and -, - also 1)
};
constexpr OpInfo kOps[] = {
    {"+", Op::Add, -1},       {"-", Op::Sub, -2},       {"*", Op::Mul, -1},
    {"/", Op::Div, -2},       {"min", Op::Min, -1},     {"max", Op::Max, -1},
    {"pow", Op::Pow, 2},      {"neg", Op::Neg, 1},      {"square", Op::Square, 1},
    {"sqrt", Op::Sqrt, 1},    {"abs", Op::Abs, 1},      {"exp", Op::Exp, 1},
    {"log", Op::Log, 1},      {"sin", Op::Sin, 1},      {"cos", Op::Cos, 1},
    {"tan", Op::Tan, 1},      {"asin", Op::Asin, 1},    {"acos", Op::Acos, 1},
    {"atan", Op::Atan, 1},
};

bool commutative(Op op) {
  return op == Op::Add || op == Op::Mul || op == Op::Min || op == Op::Max;
}

double integer_power(double a, double n) { return std::pow(a, n); }  // exact sign for a < 0

// One operation on plain values: the definition every evaluator (host, device) follows.
double apply(Op op, double a, double b) {
  switch (op) {
    case Op::Add: return a + b;
    case Op::Sub: return a - b;
    case Op::Mul: return a * b;
    case Op::Div: return a / b;
    case Op::Min: return std::min(a, b);
    case Op::Max: return std::max(a, b);
    case Op::Pow: return b == std::floor(b) ? integer_power(a, b) : std::pow(std::max(a, 0.0), b);
    case Op::Neg: return -a;
    case Op::Square: return a * a;
    case Op::Sqrt: return std::sqrt(std::max(a, 0.0));
    case Op::Abs: return std::abs(a);
    case Op::Exp: return std::exp(a);
    case Op::Log: return std::log(std::max(a, 0.0));
    case Op::Sin: return std::sin(a);
    case Op::Cos: return std::cos(a);
    case Op::Tan: return std::tan(a);
    case Op::Asin: return std::asin(std::clamp(a, -1.0, 1.0));
    case Op::Acos: return std::acos(std::clamp(a, -1.0, 1.0));
    case Op::Atan: return std::atan(a);
    default: return 0;
  }
}

struct KeyHash {
  size_t operator()(const Clause& c) const {
    uint64_t v;
    std::memcpy(&v, &c.value, 8);
    uint64_t h = uint64_t(c.op) * 0x9E3779B97F4A7C15ull ^ (uint64_t(c.a) << 32 | c.b);
    return size_t((h ^ v) * 0xBF58476D1CE4E5B9ull >> 7);
  }
};
struct KeyEq {
  bool operator()(const Clause& x, const Clause& y) const {
    return x.op == y.op && x.a == y.a && x.b == y.b &&
           std::memcmp(&x.value, &y.value, sizeof x.value) == 0;
  }
};

// Builds the tape with shared subexpressions merged and constant operations folded.
class Builder {
 public:
  uint32_t leaf(Op op, double value = 0) {
    Clause c;
    c.op = op;
    c.value = op == Op::Const ? value : 0;
    return add(c);
  }
  uint32_t unary(Op op, uint32_t a) {
    if (tape_.clauses[a].op == Op::Const) return leaf(Op::Const, apply(op, tape_.clauses[a].value, 0));
    Clause c;
    c.op = op;
    c.a = a;
    return add(c);
  }
  uint32_t binary(Op op, uint32_t a, uint32_t b) {
    const Clause &ca = tape_.clauses[a], &cb = tape_.clauses[b];
    if (ca.op == Op::Const && cb.op == Op::Const) return leaf(Op::Const, apply(op, ca.value, cb.value));
    if (a == b && (op == Op::Min || op == Op::Max)) return a;
    if (commutative(op) && a > b) std::swap(a, b);
    Clause c;
    c.op = op;
    c.a = a;
    c.b = b;
    return add(c);
  }
  // n-ary + * min max as a balanced tree (depth log2 n, so interval bounds stay tight and the
  // device's stack shallow); - and / fold left.
  uint32_t fold(Op op, std::vector<uint32_t> args) {
    if (op == Op::Sub || op == Op::Div) {
      uint32_t r = args[0];
      for (size_t i = 1; i < args.size(); ++i) r = binary(op, r, args[i]);
      return r;
    }
    while (args.size() > 1) {
      std::vector<uint32_t> next;
      for (size_t i = 0; i + 1 < args.size(); i += 2) next.push_back(binary(op, args[i], args[i + 1]));
      if (args.size() % 2) next.push_back(args.back());
      args.swap(next);
    }
    return args[0];
  }
  const Clause& at(uint32_t i) const { return tape_.clauses[i]; }
  Tape take(uint32_t root, uint32_t tree_ops) {
    // Keep only what the root uses, in order (folding can leave unused constants behind).
    Tape t = std::move(tape_);
    t.clauses.resize(root + 1);
    Tape out = shorten(t, std::vector<uint8_t>(t.clauses.size(), 0));
    out.tree_ops = tree_ops;
    return out;
  }

 private:
  uint32_t add(const Clause& c) {
    auto [it, fresh] = index_.try_emplace(c, uint32_t(tape_.clauses.size()));
    if (fresh) tape_.clauses.push_back(c);
    return it->second;
  }
  Tape tape_;
  std::unordered_map<Clause, uint32_t, KeyHash, KeyEq> index_;
};

[[noreturn]] void parse_error(const std::string& file, int line, int col, const std::string& msg) {
  throw InputError(InputErrorKind::ParseError, file, "", "line " + std::to_string(line) + " column",
                   col, msg);
}

// Outward by one ulp: libm's results are within one ulp of the true value, and so is IEEE
// rounding of + - * /, so the widened interval holds the exact range.
Interval widen(double lo, double hi) {
  if (std::isnan(lo) || std::isnan(hi)) return {-kInf, kInf};
  return {std::nextafter(lo, -kInf), std::nextafter(hi, kInf)};
}
Interval hull4(double a, double b, double c, double d) {
  for (double v : {a, b, c, d})
    if (std::isnan(v)) return {-kInf, kInf};
  return widen(std::min({a, b, c, d}), std::max({a, b, c, d}));
}

// sin over [lo, hi]: the endpoints, and 1 / -1 where a peak pi/2 + 2 pi k / a trough lies inside.
Interval sin_interval(double lo, double hi, double shift) {
  const double two_pi = 2 * std::numbers::pi;
  if (!(hi - lo < two_pi)) return {-1, 1};
  lo += shift;  // cos(x) = sin(x + pi/2): the shift's rounding is covered by the widening
  hi += shift;
  double a = std::sin(lo), b = std::sin(hi);
  Interval r = widen(std::min(a, b), std::max(a, b));
  const double peak = std::numbers::pi / 2, trough = -std::numbers::pi / 2;
  // Widen the argument range by an ulp-scale margin: a critical point at the very edge counts.
  const double m = 1e-15 * std::max({1.0, std::abs(lo), std::abs(hi)});
  if (std::ceil((lo - m - peak) / two_pi) <= std::floor((hi + m - peak) / two_pi)) r.hi = 1;
  if (std::ceil((lo - m - trough) / two_pi) <= std::floor((hi + m - trough) / two_pi)) r.lo = -1;
  r.lo = std::max(r.lo, -1.0);
  r.hi = std::min(r.hi, 1.0);
  return r;
}

Interval apply_interval(Op op, Interval a, Interval b, uint8_t* choice) {
  switch (op) {
    case Op::Add: return widen(a.lo + b.lo, a.hi + b.hi);
    case Op::Sub: return widen(a.lo - b.hi, a.hi - b.lo);
    case Op::Mul: return hull4(a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi);
    case Op::Div:
      if (b.lo <= 0 && b.hi >= 0) return {-kInf, kInf};
      return hull4(a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi);
    case Op::Min:
      if (a.hi <= b.lo) *choice = 1;
      else if (b.hi <= a.lo) *choice = 2;
      return {std::min(a.lo, b.lo), std::min(a.hi, b.hi)};
    case Op::Max:
      if (a.lo >= b.hi) *choice = 1;
      else if (b.lo >= a.hi) *choice = 2;
      return {std::max(a.lo, b.lo), std::max(a.hi, b.hi)};
    case Op::Pow: {
      if (b.lo == b.hi && b.lo == std::floor(b.lo)) {  // an integer exponent
        const double n = b.lo;
        const double p = integer_power(a.lo, n), q = integer_power(a.hi, n);
        if (n == 0) return {1, 1};
        const bool even = std::fmod(n, 2) == 0;
        if (a.lo <= 0 && a.hi >= 0 && n < 0) return {-kInf, kInf};
        if (even && a.lo < 0 && a.hi > 0) return widen(0, std::max(p, q));
        return hull4(p, q, p, q);
      }
      const double alo = std::max(a.lo, 0.0), ahi = std::max(a.hi, 0.0);
      Interval r = hull4(std::pow(alo, b.lo), std::pow(alo, b.hi), std::pow(ahi, b.lo),
                         std::pow(ahi, b.hi));
      if ((alo <= 1 && ahi >= 1) || (b.lo <= 0 && b.hi >= 0)) r = {std::min(r.lo, 1.0), std::max(r.hi, 1.0)};
      return r;
    }
    case Op::Neg: return {-a.hi, -a.lo};
    case Op::Square:
      if (a.lo >= 0) return {std::max(0.0, widen(a.lo * a.lo, 0).lo), widen(0, a.hi * a.hi).hi};
      if (a.hi <= 0) return {std::max(0.0, widen(a.hi * a.hi, 0).lo), widen(0, a.lo * a.lo).hi};
      return {0, widen(0, std::max(a.lo * a.lo, a.hi * a.hi)).hi};
    case Op::Sqrt: {
      Interval r = widen(std::sqrt(std::max(a.lo, 0.0)), std::sqrt(std::max(a.hi, 0.0)));
      r.lo = std::max(r.lo, 0.0);
      return r;
    }
    case Op::Abs:
      if (a.lo >= 0) return a;
      if (a.hi <= 0) return {-a.hi, -a.lo};
      return {0, std::max(-a.lo, a.hi)};
    case Op::Exp: {
      Interval r = widen(std::exp(a.lo), std::exp(a.hi));
      r.lo = std::max(r.lo, 0.0);
      return r;
    }
    case Op::Log: return widen(std::log(std::max(a.lo, 0.0)), std::log(std::max(a.hi, 0.0)));
    case Op::Sin: return sin_interval(a.lo, a.hi, 0);
    case Op::Cos: return sin_interval(a.lo, a.hi, std::numbers::pi / 2);
    case Op::Tan: {
      if (!(a.hi - a.lo < std::numbers::pi)) return {-kInf, kInf};
      // A pole pi/2 + k pi inside (or within rounding of an end): unbounded.
      const double m = 1e-15 * std::max({1.0, std::abs(a.lo), std::abs(a.hi)});
      if (std::ceil((a.lo - m - std::numbers::pi / 2) / std::numbers::pi) <=
          std::floor((a.hi + m - std::numbers::pi / 2) / std::numbers::pi))
        return {-kInf, kInf};
      return widen(std::tan(a.lo), std::tan(a.hi));
    }
    case Op::Asin:
      return widen(std::asin(std::clamp(a.lo, -1.0, 1.0)), std::asin(std::clamp(a.hi, -1.0, 1.0)));
    case Op::Acos:
      return widen(std::acos(std::clamp(a.hi, -1.0, 1.0)), std::acos(std::clamp(a.lo, -1.0, 1.0)));
    case Op::Atan: return widen(std::atan(a.lo), std::atan(a.hi));
    default: return {0, 0};
  }
}

}  // namespace

const char* op_name(Op op) {
  switch (op) {
    case Op::Const: return "const";
    case Op::X: return "x";
    case Op::Y: return "y";
    case Op::Z: return "z";
    default:
      for (const OpInfo& i : kOps)
        if (i.op == op) return i.name;
      return "?";
  }
}

bool is_binary(Op op) { return op >= Op::Add && op <= Op::Pow; }

size_t Tape::choice_count() const {
  size_t n = 0;
  for (const Clause& c : clauses) n += c.op == Op::Min || c.op == Op::Max;
  return n;
}

Tape parse(const std::string& text, const std::string& file,
           const std::function<void()>& check_time) {
  struct Frame {
    const OpInfo* op;
    int line, col;
    std::vector<uint32_t> args;
  };
  Builder b;
  std::vector<Frame> stack;  // explicit, so a deep tree cannot overflow the call stack
  bool have_root = false;
  uint32_t root = 0, tree_ops = 0;
  int line = 1, col = 1;
  size_t i = 0, tokens = 0;
  auto put = [&](uint32_t v, int l, int c) {
    if (stack.empty()) {
      if (have_root) parse_error(file, l, c, "a second expression after the first one ends");
      have_root = true;
      root = v;
    } else {
      stack.back().args.push_back(v);
    }
  };
  while (i < text.size()) {
    const char ch = text[i];
    if (ch == '\n') {
      ++line, col = 1, ++i;
      continue;
    }
    if (ch == ' ' || ch == '\t' || ch == '\r') {
      ++col, ++i;
      continue;
    }
    if (ch == ';') {  // a comment to the end of the line
      while (i < text.size() && text[i] != '\n') ++i;
      continue;
    }
    const int tl = line, tc = col;
    if (check_time && ++tokens % 4096 == 0) check_time();
    if (ch == '(') {
      ++i, ++col;
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i, ++col;
      size_t s = i;
      while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i])) && text[i] != '(' &&
             text[i] != ')')
        ++i;
      const std::string name = text.substr(s, i - s);
      const OpInfo* op = nullptr;
      for (const OpInfo& o : kOps)
        if (name == o.name) op = &o;
      if (!op)
        parse_error(file, line, col,
                    name.empty() ? "expected an operation after '('" : "unknown operation '" + name + "'");
      col += int(i - s);
      if (have_root && stack.empty()) parse_error(file, tl, tc, "a second expression after the first one ends");
      stack.push_back({op, tl, tc, {}});
      continue;
    }
    if (ch == ')') {
      ++i, ++col;
      if (stack.empty()) parse_error(file, tl, tc, "')' without a matching '('");
      Frame f = std::move(stack.back());
      stack.pop_back();
      const size_t n = f.args.size();
      const OpInfo& o = *f.op;
      auto need = [&](const char* what) {
        parse_error(file, f.line, f.col,
                    std::string("'") + o.name + "' takes " + what + ", got " + std::to_string(n));
      };
      uint32_t v;
      ++tree_ops;
      if (o.arity == 1) {
        if (n != 1) need("one argument");
        v = b.unary(o.op, f.args[0]);
      } else if (o.arity == 2) {
        if (n != 2) need("two arguments");
        v = b.binary(o.op, f.args[0], f.args[1]);
      } else if (o.op == Op::Sub && n == 1) {
        v = b.unary(Op::Neg, f.args[0]);
      } else {
        if (n < 1 || (o.arity == -2 && o.op == Op::Div && n < 2))
          need(o.op == Op::Div ? "two or more arguments" : "one or more arguments");
        v = b.fold(o.op, std::move(f.args));
      }
      // Folding computes in double what the device would in float: a result that is not a
      // finite float ((- (/ 1 0) (/ 1 0)) is NaN) is refused as a non-finite number is.
      if (b.at(v).op == Op::Const && !std::isfinite(float(b.at(v).value)))
        parse_error(file, f.line, f.col,
                    "'(" + std::string(o.name) + "' folds to a constant that is not a finite "
                    "float (" + std::to_string(b.at(v).value) + ")");
      put(v, f.line, f.col);
      continue;
    }
    // An atom: a number or x / y / z.
    size_t s = i;
    while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i])) && text[i] != '(' &&
           text[i] != ')' && text[i] != ';')
      ++i;
    const std::string tok = text.substr(s, i - s);
    col += int(i - s);
    uint32_t v;
    if (tok == "x" || tok == "X") {
      v = b.leaf(Op::X);
    } else if (tok == "y" || tok == "Y") {
      v = b.leaf(Op::Y);
    } else if (tok == "z" || tok == "Z") {
      v = b.leaf(Op::Z);
    } else {
      char* end = nullptr;
      const double d = std::strtod(tok.c_str(), &end);
      if (end != tok.c_str() + tok.size() || tok.empty())
        parse_error(file, tl, tc, "expected a number, x, y, z or '(', got '" + tok + "'");
      if (!std::isfinite(d)) parse_error(file, tl, tc, "the number '" + tok + "' is not finite");
      // The device evaluates in float: 1e308 is finite as a double and infinite there.
      if (!std::isfinite(float(d)))
        parse_error(file, tl, tc, "the number '" + tok + "' is beyond float range (the device's)");
      v = b.leaf(Op::Const, d);
    }
    put(v, tl, tc);
  }
  if (!stack.empty())
    parse_error(file, stack.back().line, stack.back().col,
                "'(" + std::string(stack.back().op->name) + "' is not closed before the end of the input");
  if (!have_root) parse_error(file, line, col, "no expression");
  return b.take(root, tree_ops);
}

Tape load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, "cannot open the file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

double eval(const Tape& t, double x, double y, double z) {
  std::vector<double> v(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    const Clause& c = t.clauses[i];
    switch (c.op) {
      case Op::Const: v[i] = c.value; break;
      case Op::X: v[i] = x; break;
      case Op::Y: v[i] = y; break;
      case Op::Z: v[i] = z; break;
      default: v[i] = apply(c.op, v[c.a], is_binary(c.op) ? v[c.b] : 0);
    }
  }
  return v.back();
}

Interval eval_interval(const Tape& t, Interval x, Interval y, Interval z,
                       std::vector<uint8_t>* choices) {
  std::vector<Interval> v(t.size());
  if (choices) choices->assign(t.size(), 0);
  uint8_t unused = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    const Clause& c = t.clauses[i];
    switch (c.op) {
      case Op::Const: v[i] = {c.value, c.value}; break;
      case Op::X: v[i] = x; break;
      case Op::Y: v[i] = y; break;
      case Op::Z: v[i] = z; break;
      default: {
        uint8_t ch = 0;
        v[i] = apply_interval(c.op, v[c.a], is_binary(c.op) ? v[c.b] : Interval{}, &ch);
        if (std::isnan(v[i].lo) || std::isnan(v[i].hi)) v[i] = {-kInf, kInf};
        (choices ? (*choices)[i] : unused) = ch;
      }
    }
  }
  return v.back();
}

Tape shorten(const Tape& t, const std::vector<uint8_t>& choices, std::vector<uint32_t>* kept) {
  const size_t n = t.size();
  // alias[i]: the clause that stands for i once decided min/max pass their winner through.
  std::vector<uint32_t> alias(n);
  for (size_t i = 0; i < n; ++i) {
    const Clause& c = t.clauses[i];
    const uint8_t ch = i < choices.size() ? choices[i] : 0;
    if ((c.op == Op::Min || c.op == Op::Max) && ch == 1)
      alias[i] = alias[c.a];
    else if ((c.op == Op::Min || c.op == Op::Max) && ch == 2)
      alias[i] = alias[c.b];
    else
      alias[i] = uint32_t(i);
  }
  std::vector<uint8_t> used(n, 0);
  used[alias[n - 1]] = 1;
  for (size_t k = n; k-- > 0;) {
    if (!used[k] || alias[k] != k) continue;
    const Clause& c = t.clauses[k];
    if (c.op >= Op::Add) used[alias[c.a]] = 1;
    if (is_binary(c.op)) used[alias[c.b]] = 1;
  }
  Tape out;
  out.tree_ops = t.tree_ops;
  std::vector<uint32_t> renum(n, 0);
  if (kept) kept->clear();
  for (size_t k = 0; k < n; ++k) {
    if (!used[k] || alias[k] != k) continue;
    Clause c = t.clauses[k];
    if (c.op >= Op::Add) c.a = renum[alias[c.a]];
    if (is_binary(c.op)) c.b = renum[alias[c.b]];
    renum[k] = uint32_t(out.clauses.size());
    out.clauses.push_back(c);
    if (kept) kept->push_back(uint32_t(k));
  }
  return out;
}

SlotTape allocate_slots(const Tape& t) {
  const size_t n = t.size();
  std::vector<size_t> last(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const Clause& c = t.clauses[i];
    if (c.op >= Op::Add) last[c.a] = i;
    if (is_binary(c.op)) last[c.b] = i;
  }
  last[n - 1] = n;  // the root is never freed
  SlotTape out;
  out.code.reserve(4 * n);
  std::vector<uint32_t> slot(n, 0), free_slots;
  for (size_t i = 0; i < n; ++i) {
    const Clause& c = t.clauses[i];
    if (c.op >= Op::Add && last[c.a] == i) free_slots.push_back(slot[c.a]);
    if (is_binary(c.op) && c.b != c.a && last[c.b] == i) free_slots.push_back(slot[c.b]);
    if (free_slots.empty()) {
      slot[i] = out.slots++;
    } else {
      slot[i] = free_slots.back();
      free_slots.pop_back();
    }
    uint32_t a = 0, b = 0;
    if (c.op == Op::Const) {
      const float f = float(c.value);
      std::memcpy(&a, &f, 4);
    } else if (c.op >= Op::Add) {
      a = slot[c.a];
      if (is_binary(c.op)) b = slot[c.b];
    }
    out.code.insert(out.code.end(), {uint32_t(c.op), slot[i], a, b});
  }
  out.root_slot = slot[n - 1];
  return out;
}

namespace {

// A value and its gradient (forward differentiation).
struct Dual {
  double v = 0, d[3] = {0, 0, 0};
};

Dual scaled(const Dual& a, double v, double k) {  // value v, derivative k * a'
  Dual r;
  r.v = v;
  for (int i = 0; i < 3; ++i) r.d[i] = k * a.d[i];
  return r;
}

Dual apply_dual(Op op, const Dual& a, const Dual& b) {
  Dual r;
  r.v = apply(op, a.v, b.v);
  switch (op) {
    case Op::Add: for (int i = 0; i < 3; ++i) r.d[i] = a.d[i] + b.d[i]; return r;
    case Op::Sub: for (int i = 0; i < 3; ++i) r.d[i] = a.d[i] - b.d[i]; return r;
    case Op::Mul: for (int i = 0; i < 3; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i]; return r;
    case Op::Div:
      for (int i = 0; i < 3; ++i) r.d[i] = (a.d[i] * b.v - a.v * b.d[i]) / (b.v * b.v);
      return r;
    case Op::Min: return a.v <= b.v ? scaled(a, r.v, 1) : scaled(b, r.v, 1);
    case Op::Max: return a.v >= b.v ? scaled(a, r.v, 1) : scaled(b, r.v, 1);
    case Op::Pow:
      if (b.v == std::floor(b.v)) return scaled(a, r.v, b.v * integer_power(a.v, b.v - 1));
      return a.v > 0 ? scaled(a, r.v, b.v * r.v / a.v) : scaled(a, r.v, 0);
    case Op::Neg: return scaled(a, r.v, -1);
    case Op::Square: return scaled(a, r.v, 2 * a.v);
    case Op::Sqrt: return scaled(a, r.v, a.v > 0 ? 0.5 / r.v : 0);
    case Op::Abs: return scaled(a, r.v, a.v < 0 ? -1 : 1);
    case Op::Exp: return scaled(a, r.v, r.v);
    case Op::Log: return scaled(a, r.v, a.v > 0 ? 1 / a.v : 0);
    case Op::Sin: return scaled(a, r.v, std::cos(a.v));
    case Op::Cos: return scaled(a, r.v, -std::sin(a.v));
    case Op::Tan: return scaled(a, r.v, 1 / (std::cos(a.v) * std::cos(a.v)));
    case Op::Asin: return scaled(a, r.v, std::abs(a.v) < 1 ? 1 / std::sqrt(1 - a.v * a.v) : 0);
    case Op::Acos: return scaled(a, r.v, std::abs(a.v) < 1 ? -1 / std::sqrt(1 - a.v * a.v) : 0);
    case Op::Atan: return scaled(a, r.v, 1 / (1 + a.v * a.v));
    default: return r;
  }
}

}  // namespace

double eval_code_grad(const uint32_t* code, size_t clauses, uint32_t slots, uint32_t root_slot,
                      double x, double y, double z, double grad[3]) {
  std::vector<Dual> s(std::max<uint32_t>(slots, 1));
  for (size_t k = 0; k < clauses; ++k) {
    const uint32_t* c = &code[4 * k];
    const Op op = Op(c[0]);
    Dual v;
    if (c[0] == kCopy) {
      v = s[c[2]];
    } else if (op == Op::Const) {
      float f;
      std::memcpy(&f, &c[2], 4);
      v.v = f;
    } else if (op == Op::X || op == Op::Y || op == Op::Z) {
      const int axis = int(op) - int(Op::X);
      v.v = axis == 0 ? x : axis == 1 ? y : z;
      v.d[axis] = 1;
    } else {
      v = apply_dual(op, s[c[2]], is_binary(op) ? s[c[3]] : Dual{});
    }
    s[c[1]] = v;
  }
  const Dual& f = s[root_slot];
  for (int i = 0; i < 3; ++i) grad[i] = f.d[i];
  return f.v;
}

double eval_slots(const SlotTape& t, double x, double y, double z) {
  double grad[3];
  return eval_code_grad(t.code.data(), t.size(), t.slots, t.root_slot, x, y, z, grad);
}

Tape clipped_to_box(const Tape& t, const double lo[3], const double hi[3], int dims) {
  Tape o = t;
  const uint32_t f = o.root();
  auto add = [&o](Op op, uint32_t a = 0, uint32_t b = 0, double v = 0) {
    Clause c;
    c.op = op;
    c.a = a;
    c.b = b;
    c.value = v;
    o.clauses.push_back(c);
    return uint32_t(o.clauses.size() - 1);
  };
  uint32_t var[3], c0[3], c1[3];
  for (int k = 0; k < dims; ++k) var[k] = add(k == 0 ? Op::X : k == 1 ? Op::Y : Op::Z);
  for (int k = 0; k < dims; ++k) {
    c0[k] = add(Op::Const, 0, 0, lo[k]);
    c1[k] = add(Op::Const, 0, 0, hi[k]);
  }
  uint32_t slab[3];
  for (int k = 0; k < dims; ++k)
    slab[k] = add(Op::Max, add(Op::Sub, c0[k], var[k]), add(Op::Sub, var[k], c1[k]));
  uint32_t box = add(Op::Max, slab[0], slab[1]);
  if (dims == 3) box = add(Op::Max, box, slab[2]);
  add(Op::Max, f, box);
  return o;
}

namespace {
// What one level of the bounds search may hold in shortened tapes, at most.
constexpr uint64_t kMaxBoundsSearchBytes = uint64_t(256) << 20;

std::array<double, 6> bounds_in_cube(const Tape& t, const std::string& file, double search,
                                     const SearchLimits& limits) {
  const uint64_t max_bytes =
      limits.max_bytes ? std::min(limits.max_bytes, kMaxBoundsSearchBytes) : kMaxBoundsSearchBytes;
  struct Box {
    double lo[3];
    std::shared_ptr<const Tape> tape;
  };
  const auto fail = [&file](InputErrorKind kind, const std::string& msg) {
    throw InputError(kind, file, "", "", -1, msg);
  };
  const std::string cube =
      "the search cube [-" + std::to_string(int(search)) + ", " + std::to_string(int(search)) + "]^3";
  const auto unbounded = [&](const char* how) {
    fail(InputErrorKind::BadScene, std::string("the solid f < 0 ") + how + " the faces of " +
                                       cube + ": unbounded or too large; give the object bounds");
  };
  std::vector<Box> cur{{{-search, -search, -search}, std::make_shared<const Tape>(t)}};
  double size = 2 * search;
  double blo[3], bhi[3];
  bool any_full = false;
  double flo[3] = {kInf, kInf, kInf}, fhi[3] = {-kInf, -kInf, -kInf};  // full boxes so far
  std::vector<uint8_t> choices;
  for (int level = 0;; ++level) {
    std::vector<Box> next;
    double lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
    bool edge = false;  // a box not shown empty touches the search cube's faces
    // The shortened tapes the next level holds (issue 35, case 1: a sphere under 3,000 nested
    // (+ ... 0), which no box shortens, held 1.8 GB here for 5 s before the region queue refused
    // it; 10^5 of them grew an upload's load thread past 14 GB).
    uint64_t tape_bytes = 0;
    for (const Box& b : cur) {
      if (limits.check_time) limits.check_time();
      const Interval iv = eval_interval(*b.tape, {b.lo[0], b.lo[0] + size},
                                        {b.lo[1], b.lo[1] + size}, {b.lo[2], b.lo[2] + size},
                                        &choices);
      // f >= 0 over the box: no solid (f < 0) in it. An exact 0 rounded outward is a denormal
      // below 0: below -1e-200 counts (where f touches 0 on a sheet, as in the architecture
      // model's floor, the box would otherwise never be shown empty).
      if (iv.lo >= -1e-200) continue;
      bool touches = false;
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], b.lo[k]);
        hi[k] = std::max(hi[k], b.lo[k] + size);
        touches = touches || b.lo[k] <= -search || b.lo[k] + size >= search;
      }
      if (iv.hi < 0) {  // full: in the bounds for good, no need to split
        if (touches && level > 0) unbounded("fills a box on");
        any_full = true;
        for (int k = 0; k < 3; ++k) {
          flo[k] = std::min(flo[k], b.lo[k]);
          fhi[k] = std::max(fhi[k], b.lo[k] + size);
        }
        continue;
      }
      edge = edge || touches;
      auto shortened = std::make_shared<const Tape>(shorten(*b.tape, choices));
      tape_bytes += shortened->clauses.size() * sizeof(Clause);
      if (tape_bytes > max_bytes)
        fail(InputErrorKind::TooLarge, "the bounds search would hold more than " + mib(max_bytes) +
                                           " of shortened tapes at level " +
                                           std::to_string(level + 1) + " (" +
                                           std::to_string(shortened->clauses.size()) +
                                           " clauses a box); give the object bounds");
      for (int c = 0; c < 8; ++c)
        next.push_back({{b.lo[0] + (c & 1 ? size / 2 : 0), b.lo[1] + (c & 2 ? size / 2 : 0),
                         b.lo[2] + (c & 4 ? size / 2 : 0)},
                        shortened});
    }
    for (int k = 0; k < 3; ++k) {
      blo[k] = std::min(lo[k], flo[k]);
      bhi[k] = std::max(hi[k], fhi[k]);
    }
    if (next.empty() && !any_full && lo[0] > hi[0])
      fail(InputErrorKind::EmptyMesh, "f >= 0 over the whole of " + cube + ": nothing to draw");
    const double extent = std::max({bhi[0] - blo[0], bhi[1] - blo[1], bhi[2] - blo[2]});
    if (next.empty() || size <= extent / 64 || level >= 30) {
      if (edge && level > 0) unbounded("reaches");
      break;
    }
    if (next.size() > (size_t(1) << 20))
      fail(InputErrorKind::TooLarge, "the bounds search passed 2^20 boxes at level " +
                                         std::to_string(level + 1) + "; give the object bounds");
    cur = std::move(next);
    size /= 2;
  }
  // Grown by one box: the surface lies inside, never on the box's faces.
  return {blo[0] - size, blo[1] - size, blo[2] - size, bhi[0] + size, bhi[1] + size,
          bhi[2] + size};
}
}  // namespace

std::array<double, 6> find_bounds(const Tape& t, const std::string& file, double search,
                                  const SearchLimits& limits) {
  // Cubes of side 32, 64, ... up to 2 search: the first that holds some of the solid and whose
  // faces the solid does not reach. Interval arithmetic is loose over large boxes far from the
  // origin (products of coordinates), so a small cube that holds the object proves that far
  // sooner than the largest one. A smaller cube found empty or reached only says: look wider.
  for (double s = 16; s < search; s *= 2) {
    try {
      return bounds_in_cube(t, file, s, limits);
    } catch (const InputError& e) {
      if (e.kind() != InputErrorKind::BadScene && e.kind() != InputErrorKind::EmptyMesh) throw;
    }
  }
  return bounds_in_cube(t, file, search, limits);
}

}  // namespace vismap::implicit
