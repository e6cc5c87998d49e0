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

inline i128 i128_sub(i128 a, i128 b) {
  return i128_add(a, i128_neg(b));
}

inline int i128_sign(i128 a) {
  if (a.hi < 0) return -1;
  return (a.hi != 0 || a.lo != 0) ? 1 : 0;
}

/* Converted through the magnitude: hi * 2^64 + lo with a negative hi would cancel (-1 is
 * -2^64 + (2^64 - 1), and the second term rounds to 2^64), losing up to 2^12. */
inline double i128_to_double(i128 a) {
  bool neg = a.hi < 0;
  i128 u = neg ? i128_neg(a) : a;
  double r = (double)(ulong)u.hi * 18446744073709551616.0 + (double)u.lo;
  return neg ? -r : r;
}

/* Signed 256-bit integers, two's complement in four 64-bit limbs (w[0] lowest), for the exact
 * rational sample point of a cell thinner than the fine grid (occlusion.cl): products of a 64-bit
 * value with up to 2^191 stay below 2^255. Only what that slow path needs. */
typedef struct {
  ulong w[4];
} i256;

inline i256 i256_from_long(long a) {
  i256 r;
  r.w[0] = (ulong)a;
  r.w[1] = r.w[2] = r.w[3] = a < 0 ? ~(ulong)0 : 0;
  return r;
}

inline i256 i256_from_i128(i128 a) {
  i256 r;
  r.w[0] = a.lo;
  r.w[1] = (ulong)a.hi;
  r.w[2] = r.w[3] = a.hi < 0 ? ~(ulong)0 : 0;
  return r;
}

inline i256 i256_add(i256 a, i256 b) {
  i256 r;
  ulong carry = 0;
  for (int k = 0; k < 4; ++k) {
    ulong s = a.w[k] + carry;
    ulong c1 = s < carry ? 1 : 0;
    r.w[k] = s + b.w[k];
    carry = c1 + (r.w[k] < s ? 1 : 0);
  }
  return r;
}

inline i256 i256_neg(i256 a) {
  i256 r;
  ulong carry = 1;
  for (int k = 0; k < 4; ++k) {
    r.w[k] = ~a.w[k] + carry;
    carry = (carry && r.w[k] == 0) ? 1 : 0;
  }
  return r;
}

inline i256 i256_sub(i256 a, i256 b) {
  return i256_add(a, i256_neg(b));
}

inline int i256_sign(i256 a) {
  if ((long)a.w[3] < 0) return -1;
  return (a.w[0] | a.w[1] | a.w[2] | a.w[3]) ? 1 : 0;
}

/* a * b, exact while the product stays below 2^255 in magnitude. */
inline i256 i256_mul64(i256 a, long b) {
  bool neg = (i256_sign(a) < 0) != (b < 0);
  i256 ua = i256_sign(a) < 0 ? i256_neg(a) : a;
  ulong ub = b < 0 ? (ulong)0 - (ulong)b : (ulong)b;
  i256 r;
  ulong carry = 0;
  for (int k = 0; k < 4; ++k) {
    ulong lo = ua.w[k] * ub;
    ulong hi = mul_hi(ua.w[k], ub);
    r.w[k] = lo + carry;
    carry = hi + (r.w[k] < lo ? 1 : 0);
  }
  return neg ? i256_neg(r) : r;
}

inline double i256_to_double(i256 a) {
  bool neg = i256_sign(a) < 0;
  i256 u = neg ? i256_neg(a) : a;
  double r = (double)u.w[3];
  for (int k = 2; k >= 0; --k) r = r * 18446744073709551616.0 + (double)u.w[k];
  return neg ? -r : r;
}
