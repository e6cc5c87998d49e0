/* Signed 128-bit integers for exact predicates (DESIGN §3). OpenCL C has no 128-bit type: a
 * value is hi * 2^64 + lo. Only what the predicates need: products of two 64-bit values, sums,
 * signs and a rounded conversion to double. */
typedef struct {
  ulong lo;
  long hi;
} i128;

inline i128 i128_mul64(long a, long b) {
  i128 r;
  r.lo = (ulong)a * (ulong)b; /* low half is the same for signed and unsigned */
  r.hi = mul_hi(a, b);        /* signed high half */
  return r;
}

inline i128 i128_add(i128 a, i128 b) {
  i128 r;
  r.lo = a.lo + b.lo;
  r.hi = a.hi + b.hi + (r.lo < a.lo ? 1 : 0);
  return r;
}

inline i128 i128_neg(i128 a) {
  i128 r;
  r.lo = ~a.lo + 1;
  r.hi = ~a.hi + (r.lo == 0 ? 1 : 0);
  return r;
}

inline i128 i128_sub(i128 a, i128 b) { return i128_add(a, i128_neg(b)); }

inline int i128_sign(i128 a) {
  if (a.hi < 0) return -1;
  return (a.hi != 0 || a.lo != 0) ? 1 : 0;
}

inline double i128_to_double(i128 a) {
  return (double)a.hi * 18446744073709551616.0 + (double)a.lo;
}
