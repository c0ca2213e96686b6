/* SPDX-License-Identifier: MIT */
/*
 * Portable SIMD helpers for the batched tet kernels (src/tet_forces.c): GCC/Clang vector
 * extensions of DEFSIM_VW doubles. tet_forces.c is compiled once per instruction set (generic,
 * AVX2+FMA, AVX-512), so DEFSIM_VW follows the flags of that compilation: 8 lanes with AVX-512,
 * 4 with AVX2, and 4 otherwise (the compiler splits those into SSE2 or NEON pairs).
 *
 * Everything is static inline: each compilation gets its own copies, never shared across
 * instruction sets.
 */
#ifndef DEFSIM_SIMD_H
#define DEFSIM_SIMD_H

#include <float.h>
#include <math.h>
#include <stdint.h>

#if defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#endif

#if defined(__AVX512F__)
#define DEFSIM_VW 8
#else
#define DEFSIM_VW 4
#endif

#define DEFSIM_SIMD_INLINE static inline __attribute__((always_inline))

typedef double vd __attribute__((vector_size(8 * DEFSIM_VW)));
typedef int64_t vl __attribute__((vector_size(8 * DEFSIM_VW)));   /* lane masks: -1 or 0 */

DEFSIM_SIMD_INLINE vd v_set1(double a)
{
    return a - (vd){0};
}

/* Load and store DEFSIM_VW doubles at an address aligned to 8 * DEFSIM_VW bytes. */
DEFSIM_SIMD_INLINE vd v_load(const double *p)
{
    return *(const vd *)p;
}

DEFSIM_SIMD_INLINE void v_store(double *p, vd a)
{
    *(vd *)p = a;
}

/* Lanes of a where m is set, else lanes of b. */
DEFSIM_SIMD_INLINE vd v_select(vl m, vd a, vd b)
{
    return (vd)(((vl)a & m) | ((vl)b & ~m));
}

DEFSIM_SIMD_INLINE int v_any(vl m)
{
    int64_t r = 0;
    for (int l = 0; l < DEFSIM_VW; ++l) r |= m[l];
    return r != 0;
}

DEFSIM_SIMD_INLINE vd v_sqrt(vd a)
{
#if defined(__AVX512F__)
    return (vd)_mm512_sqrt_pd((__m512d)a);
#elif defined(__AVX__)
    return (vd)_mm256_sqrt_pd((__m256d)a);
#else
    vd r;
    for (int l = 0; l < DEFSIM_VW; ++l) r[l] = sqrt(a[l]);
    return r;
#endif
}

/*
 * Natural logarithm, correctly rounded in most cases and within 1 ulp otherwise (fdlibm's
 * reduction and minimax polynomial): x = 2^k (1 + f) with 1 + f in [sqrt(1/2), sqrt(2)),
 * s = f / (2 + f), log(1 + f) = f - (f^2/2 - s (f^2/2 + R(s^2))). Valid for positive normal x;
 * lanes outside [DBL_MIN, DBL_MAX] (zero, negative, subnormal, inf, NaN) are recomputed with
 * the scalar log, so the result is exact in meaning for every input.
 */
DEFSIM_SIMD_INLINE vd v_log(vd x)
{
    const vl bits = (vl)x;
    /* Exponent and mantissa by bit manipulation; the mantissa is moved into [sqrt(1/2),
     * sqrt(2)) by taking the exponent of 1/2 for mantissas above sqrt(2). */
    const vl mant = bits & 0x000fffffffffffffLL;
    const vl big = mant > 0x6a09e667f3bccLL;   /* 1.m > sqrt(2) */
    const vl mbits = mant | (0x3ff0000000000000LL ^ (big & 0x0010000000000000LL));
    const vd m = (vd)mbits;
    /* k = biased exponent - 1023 (+1 when halved), converted exactly through 2^52 + k. */
    const vl kb = ((bits >> 52) & 0x7ff) + (big & 1);
    const vd k = (vd)(kb | 0x4330000000000000LL) - v_set1(4503599627370496.0 + 1023.0);
    const vd f = m - 1.0;
    const vd s = f / (2.0 + f);
    const vd z = s * s, w = z * z;
    const vd t1 = w * (3.999999999940941908e-01 +
                       w * (2.222219843214978396e-01 + w * 1.531383769920937332e-01));
    const vd t2 = z * (6.666666666666735130e-01 +
                       w * (2.857142874366239149e-01 +
                            w * (1.818357216161805012e-01 + w * 1.479819860511658591e-01)));
    const vd R = t1 + t2;
    const vd hfsq = 0.5 * f * f;
    vd r = k * 6.93147180369123816490e-01 -
           ((hfsq - (s * (hfsq + R) + k * 1.90821492927058770002e-10)) - f);
    const vl normal = (x >= DBL_MIN) & (x <= DBL_MAX);
    if (v_any(~normal))
        for (int l = 0; l < DEFSIM_VW; ++l)
            if (!normal[l]) r[l] = log(x[l]);
    return r;
}

#endif /* DEFSIM_SIMD_H */
