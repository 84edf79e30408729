/* The streaming kernel's matrix products: y = x @ W + b for a few rows, with W in float32 or
 * in IEEE binary16 (half precision), included by streaming_kernel.c.
 *
 * Why half-precision weights: for the paper preset a guide step reads 3.2 MB of float32
 * weights for 1..11 rows, more than a core's L2 cache, so the small-row products wait on
 * memory.  Half the bytes, converted to float32 in registers (x86 F16C: one instruction per
 * vector), and the products and sums stay in float32.  Binary16 rather than bfloat16: the
 * same bytes with 11 instead of 8 significant bits (relative rounding 2^-11 against 2^-8,
 * IEEE 754-2008 binary16), and trained weights lie far inside its range (|w| <= 65504; the
 * Python packer refuses a unit beyond it).  Without F16C the conversion is exact in software,
 * so every machine computes the same numbers, only more slowly.
 */
#include <stdint.h>
#include <string.h>
#if defined(__F16C__)
#include <immintrin.h>
#endif

#if defined(__AVX512F__)
#define VL 16
#define MB 12 /* rows per register block: 2 * MB accumulators + 2 weights + 1 broadcast <= 32 */
#else
#define VL 8
#define MB 6 /* 16 vector registers (AVX2): 12 accumulators + 2 weights + 1 broadcast */
#endif
#define NB (2 * VL)
typedef float vec __attribute__((vector_size(VL * sizeof(float))));

static inline vec vload(const float *p) { vec v; memcpy(&v, p, sizeof v); return v; }
static inline void vstore(float *p, vec v) { memcpy(p, &v, sizeof v); }

/* binary16 -> float32, exactly (every binary16 value is a float32 value). */
static inline float half_to_float(uint16_t h) {
#if defined(__F16C__)
    return _cvtsh_ss(h);
#else
    uint32_t sign = (uint32_t)(h & 0x8000) << 16, exp = (h >> 10) & 0x1f, man = h & 0x3ff, bits;
    if (exp == 0x1f) bits = sign | 0x7f800000u | (man << 13); /* inf, nan */
    else if (exp) bits = sign | ((exp + 112) << 23) | (man << 13);
    else if (!man) bits = sign; /* +-0 */
    else { /* subnormal: man * 2^-24, normalised */
        int e = -1;
        do { man <<= 1; e++; } while (!(man & 0x400));
        bits = sign | ((uint32_t)(112 - e) << 23) | ((man & 0x3ff) << 13);
    }
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
#endif
}

static inline vec hload(const uint16_t *p) {
    vec v;
#if defined(__F16C__) && VL == 16
    __m512 r = _mm512_cvtph_ps(_mm256_loadu_si256((const __m256i *)p));
    memcpy(&v, &r, sizeof v);
#elif defined(__F16C__)
    __m256 r = _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)p));
    memcpy(&v, &r, sizeof v);
#else
    for (int j = 0; j < VL; j++) v[j] = half_to_float(p[j]);
#endif
    return v;
}

static inline float fscalar(const float *p) { return *p; }
static inline float hscalar(const uint16_t *p) { return half_to_float(*p); }

/* Weight layout: panels.  A (K, N) weight is stored as its N / NB column panels, each (K, NB)
 * row-major, one after the other, then the last N % NB columns as a (K, N % NB) row-major block
 * (the Python packer writes it; pgchtc_panel_width tells it NB).  A register block then reads
 * its weights as one or two contiguous streams instead of one cache line every N floats, which
 * the prefetcher keeps up with: f_theta of the paper preset, float32, 1.16 -> 0.84 ms per frame
 * (11..1 rows, one thread, AVX2).
 *
 * y[m, n0 : n0 + NV * VL] = b + x[m, :] @ W[:, n0 : n0 + NV * VL] for MM rows, with the
 * MM * NV accumulators in registers: each weight vector loaded is used MM times.  n0 is a
 * multiple of NB, NV is 2 or 4 (one or two panels). */
#define DEF_BLOCK(T, WT, LOAD, MM, NV)                                                             \
    static void block_##T##_##MM##_##NV(const float *x, int K, const WT *W, int N, const float *b, float *y, int n0) { \
        vec acc[MM][NV];                                                                           \
        for (int m = 0; m < MM; m++)                                                               \
            for (int j = 0; j < NV; j++) acc[m][j] = vload(b + n0 + j * VL);                       \
        for (int k = 0; k < K; k++) {                                                              \
            const WT *w = W + (size_t)n0 * K + (size_t)k * NB;                                     \
            vec wv[NV];                                                                            \
            for (int j = 0; j < NV; j++) wv[j] = LOAD(w + (j / 2) * (size_t)NB * K + (j % 2) * VL); \
            for (int m = 0; m < MM; m++) {                                                         \
                float xs = x[(size_t)m * K + k];                                                   \
                for (int j = 0; j < NV; j++) acc[m][j] += xs * wv[j];                              \
            }                                                                                      \
        }                                                                                          \
        for (int m = 0; m < MM; m++)                                                               \
            for (int j = 0; j < NV; j++) vstore(y + (size_t)m * N + n0 + j * VL, acc[m][j]);       \
    }

/* y (M, N) = x (M, K) @ W (K, N) + b: a Linear layer with its weight stored transposed.
 * Few rows get four vectors per row, so that enough independent FMA chains hide their latency. */
#if MB > 6
#define WIDE_ROWS 6 /* 6 * 4 = 24 accumulators */
#define DEF_LINEAR(T, WT, LOAD, SCALAR)                                                                            \
    DEF_BLOCK(T, WT, LOAD, 1, 4) DEF_BLOCK(T, WT, LOAD, 2, 4) DEF_BLOCK(T, WT, LOAD, 3, 4)                       \
    DEF_BLOCK(T, WT, LOAD, 4, 4) DEF_BLOCK(T, WT, LOAD, 5, 4) DEF_BLOCK(T, WT, LOAD, 6, 4)                       \
    DEF_BLOCK(T, WT, LOAD, 1, 2) DEF_BLOCK(T, WT, LOAD, 2, 2) DEF_BLOCK(T, WT, LOAD, 3, 2)                       \
    DEF_BLOCK(T, WT, LOAD, 4, 2) DEF_BLOCK(T, WT, LOAD, 5, 2) DEF_BLOCK(T, WT, LOAD, 6, 2)                       \
    DEF_BLOCK(T, WT, LOAD, 7, 2) DEF_BLOCK(T, WT, LOAD, 8, 2) DEF_BLOCK(T, WT, LOAD, 9, 2)                       \
    DEF_BLOCK(T, WT, LOAD, 10, 2) DEF_BLOCK(T, WT, LOAD, 11, 2) DEF_BLOCK(T, WT, LOAD, 12, 2)                    \
    static void (*const BLOCKS2_##T[MB + 1])(const float *, int, const WT *, int, const float *, float *, int) = { \
        0, block_##T##_1_2, block_##T##_2_2, block_##T##_3_2, block_##T##_4_2, block_##T##_5_2, block_##T##_6_2, \
        block_##T##_7_2, block_##T##_8_2, block_##T##_9_2, block_##T##_10_2, block_##T##_11_2, block_##T##_12_2}; \
    static void (*const BLOCKS4_##T[WIDE_ROWS + 1])(const float *, int, const WT *, int, const float *, float *, int) = { \
        0, block_##T##_1_4, block_##T##_2_4, block_##T##_3_4, block_##T##_4_4, block_##T##_5_4, block_##T##_6_4}; \
    DEF_LINEAR_BODY(T, WT, SCALAR)
#else
#define WIDE_ROWS 2 /* 2 * 4 = 8 accumulators: 3 * 4 spilled (12 + 4 weights + 1 broadcast > 16 registers) */
#define DEF_LINEAR(T, WT, LOAD, SCALAR)                                                                            \
    DEF_BLOCK(T, WT, LOAD, 1, 4) DEF_BLOCK(T, WT, LOAD, 2, 4)                                                     \
    DEF_BLOCK(T, WT, LOAD, 1, 2) DEF_BLOCK(T, WT, LOAD, 2, 2) DEF_BLOCK(T, WT, LOAD, 3, 2)                       \
    DEF_BLOCK(T, WT, LOAD, 4, 2) DEF_BLOCK(T, WT, LOAD, 5, 2) DEF_BLOCK(T, WT, LOAD, 6, 2)                       \
    static void (*const BLOCKS2_##T[MB + 1])(const float *, int, const WT *, int, const float *, float *, int) = { \
        0, block_##T##_1_2, block_##T##_2_2, block_##T##_3_2, block_##T##_4_2, block_##T##_5_2, block_##T##_6_2}; \
    static void (*const BLOCKS4_##T[WIDE_ROWS + 1])(const float *, int, const WT *, int, const float *, float *, int) = { \
        0, block_##T##_1_4, block_##T##_2_4};                                                                     \
    DEF_LINEAR_BODY(T, WT, SCALAR)
#endif

#define DEF_LINEAR_BODY(T, WT, SCALAR)                                                                             \
    static void linear_##T(const float *x, int M, int K, const WT *W, const float *b, int N, float *y) {           \
        int n2 = N - N % NB, n4 = N - N % (2 * NB);                                                                 \
        for (int m0 = 0; m0 < M;) {                                                                                 \
            int mm = M - m0 < MB ? M - m0 : MB;                                                                     \
            const float *xm = x + (size_t)m0 * K;                                                                   \
            float *ym = y + (size_t)m0 * N;                                                                         \
            int n0 = 0;                                                                                             \
            if (mm <= WIDE_ROWS)                                                                                    \
                for (; n0 < n4; n0 += 2 * NB) BLOCKS4_##T[mm](xm, K, W, N, b, ym, n0);                              \
            for (; n0 < n2; n0 += NB) BLOCKS2_##T[mm](xm, K, W, N, b, ym, n0);                                      \
            m0 += mm;                                                                                               \
        }                                                                                                           \
        const WT *tail = W + (size_t)n2 * K; /* the last N - n2 columns, (K, N - n2) row-major */                 \
        for (int m = 0; m < M; m++)                                                                                 \
            for (int n = n2; n < N; n++) {                                                                          \
                float s = b[n];                                                                                     \
                for (int k = 0; k < K; k++) s += x[(size_t)m * K + k] * SCALAR(tail + (size_t)k * (N - n2) + n - n2); \
                y[(size_t)m * N + n] = s;                                                                           \
            }                                                                                                       \
    }

DEF_LINEAR(f32, float, vload, fscalar)
DEF_LINEAR(f16, uint16_t, hload, hscalar)

/* A unit's parameters: float32 always (biases, norms and, by default, the weights), and optionally a
 * binary16 copy of the same floats at the same offsets, whose matrices the products then read. */
typedef struct {
    const float *f;
    const uint16_t *h; /* NULL: float32 weights */
} params_t;

/* The Linear layer whose float32 weight starts at W in the unit p (its binary16 copy if it has one). */
static inline void linear(const float *x, int M, int K, params_t p, const float *W, const float *b, int N, float *y) {
    if (p.h)
        linear_f16(x, M, K, p.h + (W - p.f), b, N, y);
    else
        linear_f32(x, M, K, W, b, N, y);
}

/* Columns per weight panel (see the layout above), for the Python packer. */
int pgchtc_panel_width(void) { return NB; }

/* For the tests: the kernel's binary16 -> float32 conversion. */
void pgchtc_half_to_float(const uint16_t *x, float *y, int n) {
    for (int i = 0; i < n; i++) y[i] = half_to_float(x[i]);
}
