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

/*
 * Rows of three doubles (a vertex's x, y, z) to and from lane vectors. With AVX2 each row is
 * one masked 3-double load (the mask keeps it inside the array), and 4 x 4 transposes turn
 * rows into lanes; the generic version goes lane by lane.
 */
#if defined(__AVX2__)
DEFSIM_SIMD_INLINE __m256d row3_load(const double *p)
{
#if defined(__AVX512VL__)
    return _mm256_maskz_loadu_pd(0x7, p);
#else
    return _mm256_maskload_pd(p, _mm256_setr_epi64x(-1, -1, -1, 0));
#endif
}

DEFSIM_SIMD_INLINE void row3_store(double *p, __m256d a)
{
#if defined(__AVX512VL__)
    _mm256_mask_storeu_pd(p, 0x7, a);
#else
    _mm256_maskstore_pd(p, _mm256_setr_epi64x(-1, -1, -1, 0), a);
#endif
}

/* Four rows [x y z *] to lanes X, Y, Z. */
DEFSIM_SIMD_INLINE void rows4_to_lanes(__m256d r0, __m256d r1, __m256d r2, __m256d r3,
                                       __m256d *X, __m256d *Y, __m256d *Z)
{
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    *X = _mm256_permute2f128_pd(t0, t2, 0x20);
    *Y = _mm256_permute2f128_pd(t1, t3, 0x20);
    *Z = _mm256_permute2f128_pd(t0, t2, 0x31);
}

/* Lanes X, Y, Z to four rows [x y z z]. */
DEFSIM_SIMD_INLINE void lanes_to_rows4(__m256d X, __m256d Y, __m256d Z, __m256d r[4])
{
    const __m256d t0 = _mm256_unpacklo_pd(X, Y), t1 = _mm256_unpackhi_pd(X, Y);
    const __m256d t2 = _mm256_unpacklo_pd(Z, Z), t3 = _mm256_unpackhi_pd(Z, Z);
    r[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
    r[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    r[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    r[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}
#endif

/* p[c] lane l = rows[l][c]. */
DEFSIM_SIMD_INLINE void v_gather_rows3(const double *const rows[DEFSIM_VW], vd p[3])
{
#if defined(__AVX2__)
    for (int h = 0; h < DEFSIM_VW / 4; ++h) {
        __m256d X, Y, Z;
        rows4_to_lanes(row3_load(rows[4 * h]), row3_load(rows[4 * h + 1]),
                       row3_load(rows[4 * h + 2]), row3_load(rows[4 * h + 3]), &X, &Y, &Z);
#if DEFSIM_VW == 8
        if (h == 0) {
            p[0] = (vd)_mm512_castpd256_pd512(X);
            p[1] = (vd)_mm512_castpd256_pd512(Y);
            p[2] = (vd)_mm512_castpd256_pd512(Z);
        } else {
            p[0] = (vd)_mm512_insertf64x4((__m512d)p[0], X, 1);
            p[1] = (vd)_mm512_insertf64x4((__m512d)p[1], Y, 1);
            p[2] = (vd)_mm512_insertf64x4((__m512d)p[2], Z, 1);
        }
#else
        p[0] = (vd)X; p[1] = (vd)Y; p[2] = (vd)Z;
#endif
    }
#else
    for (int c = 0; c < 3; ++c)
        for (int l = 0; l < DEFSIM_VW; ++l) p[c][l] = rows[l][c];
#endif
}

/* rows[l][c] += h[c] lane l, for the first nl lanes. */
DEFSIM_SIMD_INLINE void v_scatter_add_rows3(double *const rows[DEFSIM_VW], const vd h[3], int nl)
{
#if defined(__AVX2__)
    for (int q = 0; q < DEFSIM_VW / 4; ++q) {
        __m256d X, Y, Z, r[4];
#if DEFSIM_VW == 8
        X = q ? _mm512_extractf64x4_pd((__m512d)h[0], 1) : _mm512_castpd512_pd256((__m512d)h[0]);
        Y = q ? _mm512_extractf64x4_pd((__m512d)h[1], 1) : _mm512_castpd512_pd256((__m512d)h[1]);
        Z = q ? _mm512_extractf64x4_pd((__m512d)h[2], 1) : _mm512_castpd512_pd256((__m512d)h[2]);
#else
        X = (__m256d)h[0]; Y = (__m256d)h[1]; Z = (__m256d)h[2];
#endif
        lanes_to_rows4(X, Y, Z, r);
        for (int l = 0; l < 4 && 4 * q + l < nl; ++l)
            row3_store(rows[4 * q + l], _mm256_add_pd(row3_load(rows[4 * q + l]), r[l]));
    }
#else
    for (int l = 0; l < nl && l < DEFSIM_VW; ++l)
        for (int c = 0; c < 3; ++c) rows[l][c] += h[c][l];
#endif
}

#endif /* DEFSIM_SIMD_H */
