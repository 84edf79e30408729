/* One streaming frame of PG-CHTC (paper Algorithm 1) in plain C, for CPU inference.
 *
 * The same arithmetic as learners.cascade.StreamingCascade._frame: for each guide, the
 * static backbone f_theta (BatchNorm folded into its Linear layers) and the causal
 * Transformer residual g_phi reading a ring cache of the last `window` frames (paper
 * Eqs. (7)-(8)), in float32, then ln T += clamp(ln r_MLP + ln(1 + r_TR)).  As in torch,
 * the unit inputs are normalised and the chain ln T is summed in float64
 * (learners.cascade.normalised_geometry says why).  Only the order of the float32 sums
 * and the erf approximation differ from torch's, so results agree to float32 rounding
 * of the units, amplified along the chain as any float32 run of the cascade is.
 *
 * Why C: a frame is hundreds of small matrix products (11 sequential guide steps of
 * 11..1 rows for N = 12), so in torch their dispatch costs as much as their arithmetic.
 * Here each product is one register-blocked loop over GCC vector types, which the
 * compiler maps to the widest SIMD the machine has.
 *
 * Two cores: f_theta and g_phi of a guide step read the same unit input and nothing of
 * each other, and cost about the same for the paper preset (0.40 M and 0.39 M multiply-adds
 * per row in their Linear layers), so with threads = 2 a helper thread runs g_phi while the
 * calling thread runs f_theta, meeting once per guide step.  Each part does the same arithmetic in the same
 * order either way, so one and two threads give the same bits.
 *
 * Layouts (float32 unless said, C order):
 *   units[u]  : one unit's parameters, in the order the Python packer writes them
 *               (learners/streaming_native.py, _pack_unit).
 *   caches[g] : guide g's ring caches, for each layer keys then values, each
 *               (S_g, H, window, dk) with S_g = n_sets - 1 - g streams.
 */
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>
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

enum { C_N_SETS, C_N_GUIDES, C_TIED, C_N_HIDDEN, C_HIDDEN0, C_RESIDUAL = C_HIDDEN0 + 4, C_D, C_H, C_WINDOW, C_FF, C_LAYERS, C_LEN };

static inline vec vload(const float *p) { vec v; memcpy(&v, p, sizeof v); return v; }
static inline void vstore(float *p, vec v) { memcpy(p, &v, sizeof v); }

/* y[m, n0 : n0 + NV * VL] = b + x[m, :] @ W[:, n0 : n0 + NV * VL] for MM rows, with the
 * MM * NV accumulators in registers: each weight vector loaded is used MM times. */
#define DEF_BLOCK(MM, NV)                                                                          \
    static void block_##MM##_##NV(const float *x, int K, const float *W, int N, const float *b, float *y, int n0) { \
        vec acc[MM][NV];                                                                           \
        for (int m = 0; m < MM; m++)                                                               \
            for (int j = 0; j < NV; j++) acc[m][j] = vload(b + n0 + j * VL);                       \
        for (int k = 0; k < K; k++) {                                                              \
            const float *w = W + (size_t)k * N + n0;                                               \
            vec wv[NV];                                                                            \
            for (int j = 0; j < NV; j++) wv[j] = vload(w + j * VL);                                \
            for (int m = 0; m < MM; m++) {                                                         \
                float xs = x[(size_t)m * K + k];                                                   \
                for (int j = 0; j < NV; j++) acc[m][j] += xs * wv[j];                              \
            }                                                                                      \
        }                                                                                          \
        for (int m = 0; m < MM; m++)                                                               \
            for (int j = 0; j < NV; j++) vstore(y + (size_t)m * N + n0 + j * VL, acc[m][j]);       \
    }
/* Few rows: four vectors per row, so that enough independent FMA chains hide their latency. */
DEF_BLOCK(1, 4) DEF_BLOCK(2, 4) DEF_BLOCK(3, 4)
DEF_BLOCK(1, 2) DEF_BLOCK(2, 2) DEF_BLOCK(3, 2) DEF_BLOCK(4, 2) DEF_BLOCK(5, 2) DEF_BLOCK(6, 2)
#if MB > 6
DEF_BLOCK(4, 4) DEF_BLOCK(5, 4) DEF_BLOCK(6, 4)
DEF_BLOCK(7, 2) DEF_BLOCK(8, 2) DEF_BLOCK(9, 2) DEF_BLOCK(10, 2) DEF_BLOCK(11, 2) DEF_BLOCK(12, 2)
#endif

typedef void (*block_fn)(const float *, int, const float *, int, const float *, float *, int);
static const block_fn BLOCKS2[MB + 1] = {0, block_1_2, block_2_2, block_3_2, block_4_2, block_5_2, block_6_2,
#if MB > 6
                                         block_7_2, block_8_2, block_9_2, block_10_2, block_11_2, block_12_2
#endif
};
#if MB > 6
#define WIDE_ROWS 6 /* 6 * 4 = 24 accumulators */
static const block_fn BLOCKS4[WIDE_ROWS + 1] = {0, block_1_4, block_2_4, block_3_4, block_4_4, block_5_4, block_6_4};
#else
#define WIDE_ROWS 3 /* 3 * 4 = 12 accumulators */
static const block_fn BLOCKS4[WIDE_ROWS + 1] = {0, block_1_4, block_2_4, block_3_4};
#endif

/* y (M, N) = x (M, K) @ W (K, N) + b: a Linear layer with its weight stored transposed. */
static void linear(const float *x, int M, int K, const float *W, const float *b, int N, float *y) {
    int n2 = N - N % NB, n4 = N - N % (2 * NB);
    for (int m0 = 0; m0 < M;) {
        int mm = M - m0 < MB ? M - m0 : MB;
        const float *xm = x + (size_t)m0 * K;
        float *ym = y + (size_t)m0 * N;
        int n0 = 0;
        if (mm <= WIDE_ROWS)
            for (; n0 < n4; n0 += 2 * NB) BLOCKS4[mm](xm, K, W, N, b, ym, n0);
        for (; n0 < n2; n0 += NB) BLOCKS2[mm](xm, K, W, N, b, ym, n0);
        m0 += mm;
    }
    for (int m = 0; m < M; m++)
        for (int n = n2; n < N; n++) {
            float s = b[n];
            for (int k = 0; k < K; k++) s += x[(size_t)m * K + k] * W[(size_t)k * N + n];
            y[(size_t)m * N + n] = s;
        }
}

/* erf(x) as a branch-free rational function, so that the GELU loop below is vectorised
 * (libm's erff is a scalar call per element: 1.65 against 1.07 ms per frame for the paper
 * preset, with the same agreement with torch's batch inference).  The odd/even polynomials
 * on [-4, 4] are Eigen's generic_fast_erf_float (also XLA's); the test suite bounds its
 * error against torch.erf (3.3e-7 absolute).  Outside [-4, 4], erf is +-1 in float32. */
static inline float erf_rational(float x) {
    x = x > 4.f ? 4.f : (x < -4.f ? -4.f : x);
    float x2 = x * x;
    float p = x2 * -2.72614225801306e-10f + 2.77068142495902e-08f;
    p = x2 * p - 2.10102402082508e-06f;
    p = x2 * p - 5.69250639462346e-05f;
    p = x2 * p - 7.34990630326855e-04f;
    p = x2 * p - 2.95459980854025e-03f;
    p = x2 * p - 1.60960333262415e-02f;
    float q = x2 * -1.45660718464996e-05f - 2.13374055278905e-04f;
    q = x2 * q - 1.68282697438203e-03f;
    q = x2 * q - 7.37332916720468e-03f;
    q = x2 * q - 1.42647390514189e-02f;
    return x * p / q;
}

static void gelu(float *x, size_t n) { /* exact (erf) GELU, as torch.nn.GELU() */
    for (size_t i = 0; i < n; i++) x[i] = 0.5f * x[i] * (1.0f + erf_rational(x[i] * (float)M_SQRT1_2));
}

/* For the tests: the erf the kernel uses. */
void pgchtc_erf(const float *x, float *y, int n) {
    for (int i = 0; i < n; i++) y[i] = erf_rational(x[i]);
}

/* Sums over a row, VL lanes at a time: a scalar loop is one chain of dependent adds, which
 * the compiler may not reorder (IEEE), so it runs at the adder's latency, not its rate.
 * A different order of the same sum: agreement with torch is to float32 rounding, as for
 * the matrix products. */
static inline float hsum(vec v) {
    float s = 0.f;
    for (int j = 0; j < VL; j++) s += v[j];
    return s;
}

static inline float dot(const float *a, const float *b, int n) {
    vec acc = {0};
    int i = 0;
    for (; i + VL <= n; i += VL) acc += vload(a + i) * vload(b + i);
    float s = hsum(acc);
    for (; i < n; i++) s += a[i] * b[i];
    return s;
}

static inline float row_sum(const float *a, int n) {
    vec acc = {0};
    int i = 0;
    for (; i + VL <= n; i += VL) acc += vload(a + i);
    float s = hsum(acc);
    for (; i < n; i++) s += a[i];
    return s;
}

static inline float centred_square_sum(const float *a, int n, float c) {
    vec acc = {0}, cv = (vec){0} + c;
    int i = 0;
    for (; i + VL <= n; i += VL) {
        vec d = vload(a + i) - cv;
        acc += d * d;
    }
    float s = hsum(acc);
    for (; i < n; i++) s += (a[i] - c) * (a[i] - c);
    return s;
}

static void layer_norm(const float *x, int M, int D, const float *g, const float *b, float *y) { /* eps 1e-5, as nn.LayerNorm */
    for (int m = 0; m < M; m++) {
        const float *r = x + (size_t)m * D;
        float mean = row_sum(r, D) / D;
        float var = centred_square_sum(r, D, mean);
        float inv = 1.0f / sqrtf(var / D + 1e-5f);
        for (int i = 0; i < D; i++) y[(size_t)m * D + i] = (r[i] - mean) * inv * g[i] + b[i];
    }
}

static float softplus(float x) { return x > 20.f ? x : log1pf(expf(x)); } /* torch's threshold 20 */

/* The widest activation of a unit: sizes the scratch buffers. */
static int widest(const int *cfg) {
    int w = 8;
    for (int i = 0; i < cfg[C_N_HIDDEN]; i++) w = cfg[C_HIDDEN0 + i] > w ? cfg[C_HIDDEN0 + i] : w;
    if (3 * cfg[C_D] > w) w = 3 * cfg[C_D];
    return cfg[C_FF] > w ? cfg[C_FF] : w;
}

/* f_theta of a guide step: ln r_MLP (M, 3) into ratio (paper Eq. (8), its first factor).
 * x: the normalised unit inputs (M, 8) of paper Eq. (7).  buf: 2 * M * widest(cfg) floats. */
/* noinline: the calling thread and the helper run the very same machine code, so one and
 * two threads give the same bits whatever the compiler would inline where. */
__attribute__((noinline)) static void backbone_step(const int *cfg, const float *P, const float *x, int M, float *buf, float *ratio) {
    int n_hidden = cfg[C_N_HIDDEN], wide = widest(cfg);
    float *a = buf, *b = buf + (size_t)M * wide;
    /* (Linear [BN folded] -> GELU) per hidden layer, then Linear -> softplus + 0.01 */
    const float *in = x;
    int K = 8;
    for (int i = 0; i < n_hidden; i++) {
        int N = cfg[C_HIDDEN0 + i];
        float *out = (i % 2) ? b : a;
        linear(in, M, K, P, P + (size_t)K * N, N, out);
        P += (size_t)K * N + N;
        gelu(out, (size_t)M * N);
        in = out, K = N;
    }
    linear(in, M, K, P, P + (size_t)K * 3, 3, ratio);
    for (int i = 0; i < M * 3; i++) ratio[i] = logf(softplus(ratio[i]) + 0.01f);
}

/* g_phi of a guide step: the temporal head's pre-tanh output (M, 3) into tr, reading and
 * updating the guide's ring caches at `slot`.  P: the unit's g_phi parameters, which follow
 * f_theta's (backbone_floats) in a packed unit.
 * buf: M * (2 * widest(cfg) + d_model) floats. */
__attribute__((noinline)) static void residual_step(const int *cfg, const float *P, const float *x, int M, float *cache,
                                                    int slot, int seen, float *buf, float *tr) {
    int wide = widest(cfg);
    int D = cfg[C_D], F = cfg[C_FF], H = cfg[C_H], W = cfg[C_WINDOW];
    float *a = buf, *b = buf + (size_t)M * wide, *h = b + (size_t)M * wide;
    int dk = D / H;
    float scale = 1.0f / sqrtf((float)dk);
    linear(x, M, 8, P, P + 8 * D, D, h); /* embed */
    P += 8 * D + D;
    for (int l = 0; l < cfg[C_LAYERS]; l++) {
        const float *ln1g = P, *ln1b = P + D, *Wqkv = P + 2 * D, *bqkv = Wqkv + (size_t)D * 3 * D;
        const float *Wo = bqkv + 3 * D, *bo = Wo + (size_t)D * D, *lag_bias = bo + D;
        const float *ln2g = lag_bias + H * W, *ln2b = ln2g + D, *W1 = ln2b + D, *b1 = W1 + (size_t)D * F;
        const float *W2 = b1 + F, *b2 = W2 + (size_t)F * D;
        P = b2 + D;
        float *keys = cache + (size_t)2 * l * M * H * W * dk, *vals = keys + (size_t)M * H * W * dk;
        layer_norm(h, M, D, ln1g, ln1b, a);
        linear(a, M, D, Wqkv, bqkv, 3 * D, b); /* q | k | v per row */
        float *att = a; /* (M, D): attention output before the out projection */
        for (int s = 0; s < M; s++)
            for (int hd = 0; hd < H; hd++) {
                const float *q = b + (size_t)s * 3 * D + hd * dk;
                float *K_ = keys + ((size_t)(s * H + hd) * W) * dk, *V_ = vals + ((size_t)(s * H + hd) * W) * dk;
                memcpy(K_ + (size_t)slot * dk, q + D, dk * sizeof(float));
                memcpy(V_ + (size_t)slot * dk, q + 2 * D, dk * sizeof(float));
                float sc[W], mx = -INFINITY;
                for (int w = 0; w < W; w++) {
                    int lag = ((slot - w) % W + W) % W;
                    if (lag > seen) { sc[w] = -INFINITY; continue; }
                    sc[w] = dot(q, K_ + (size_t)w * dk, dk) * scale + lag_bias[hd * W + lag];
                    if (sc[w] > mx) mx = sc[w];
                }
                float z = 0.f;
                for (int w = 0; w < W; w++) { sc[w] = sc[w] == -INFINITY ? 0.f : expf(sc[w] - mx); z += sc[w]; }
                float *o = att + (size_t)s * D + hd * dk;
                for (int i = 0; i < dk; i++) o[i] = 0.f;
                for (int w = 0; w < W; w++) {
                    if (sc[w] == 0.f) continue;
                    float p = sc[w] / z;
                    for (int i = 0; i < dk; i++) o[i] += p * V_[(size_t)w * dk + i];
                }
            }
        linear(att, M, D, Wo, bo, D, b);
        for (size_t i = 0; i < (size_t)M * D; i++) h[i] += b[i];
        layer_norm(h, M, D, ln2g, ln2b, a);
        linear(a, M, D, W1, b1, F, b);
        gelu(b, (size_t)M * F);
        linear(b, M, F, W2, b2, D, a);
        for (size_t i = 0; i < (size_t)M * D; i++) h[i] += a[i];
    }
    layer_norm(h, M, D, P, P + D, a);
    P += 2 * D;
    linear(a, M, D, P, P + (size_t)D * 3, 3, tr);
}

/* ln r = clamp(ln r_MLP + ln(1 + 0.5 tanh(tr))) (paper Eq. (8)), added to log_t (M, 3, float64). */
static void add_log_ratio(const float *ratio, const float *tr, int M, float bound, double *log_t) {
    for (int i = 0; i < M * 3; i++) {
        float v = tr ? ratio[i] + log1pf(0.5f * tanhf(tr[i])) : ratio[i];
        v = v < -bound ? -bound : (v > bound ? bound : v);
        log_t[i] += (double)v;
    }
}

/* Size in floats of the scratch buffer one part of a guide step (backbone_step or residual_step) needs for M streams. */
static size_t scratch_floats(const int *cfg, int M) { return (size_t)M * (2 * widest(cfg) + cfg[C_D]) + 64; }

/* Floats of f_theta's parameters, at the start of a packed unit. */
static long backbone_floats(const int *cfg) {
    long n = 0, K = 8;
    for (int i = 0; i < cfg[C_N_HIDDEN]; i++) n += K * cfg[C_HIDDEN0 + i] + cfg[C_HIDDEN0 + i], K = cfg[C_HIDDEN0 + i];
    return n + K * 3 + 3;
}

/* Floats in one unit's packed parameters (the Python packer checks its layout against this). */
long pgchtc_unit_floats(const int *cfg) {
    long n = backbone_floats(cfg), D = cfg[C_D], F = cfg[C_FF], H = cfg[C_H], W = cfg[C_WINDOW];
    if (cfg[C_RESIDUAL])
        n += 8 * D + D + cfg[C_LAYERS] * (2 * D + D * 3 * D + 3 * D + D * D + D + H * W + 2 * D + D * F + F + F * D + D) + 2 * D + D * 3 + 3;
    return n;
}

/* Floats in guide g's ring caches: keys and values of every layer for its n_sets - 1 - g streams. */
long pgchtc_cache_floats(const int *cfg, int g) {
    if (!cfg[C_RESIDUAL]) return 0;
    return 2L * cfg[C_LAYERS] * (cfg[C_N_SETS] - 1 - g) * cfg[C_WINDOW] * cfg[C_D];
}

/* What the g_phi helper thread of a frame works on: guide `step` is posted when `go` reaches
 * step + 1 and finished when `done` does; go = -1 ends the thread. */
typedef struct {
    const int *cfg;
    const float *const *units;
    float *const *caches;
    int slot, seen;
    const float *x; /* the posted guide's unit inputs */
    int guide, M;
    float *buf, *tr;
    atomic_int go, done;
    atomic_int sleepers; /* threads blocked (or about to block) in wait_for */
} helper_t;

/* Pauses a waiter spins before it blocks: about 50-200 us on x86, longer than the usual wait at a
 * guide step on an idle machine, far shorter than a scheduler time slice.  On a busy machine the
 * other thread may not be running at all, and spinning would take the core it needs; so the
 * waiter then sleeps in the kernel (a futex) until the flag is posted. */
#define SPIN_PAUSES 4096

static void pause_once(void) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

static int wait_for(atomic_int *flag, atomic_int *sleepers, int value) {
    for (unsigned spins = 0;; spins++) {
        int v = atomic_load_explicit(flag, memory_order_seq_cst);
        if (v == value || v < 0) return v;
        if (spins < SPIN_PAUSES) {
            pause_once();
            continue;
        }
#if defined(__linux__)
        /* Announce the sleep, then re-read: a post either sees the announcement and wakes us, or
         * happened before the re-read (seq_cst orders both pairs), so no wake-up is lost; and the
         * futex sleeps only while the flag still holds v. */
        atomic_fetch_add_explicit(sleepers, 1, memory_order_seq_cst);
        if (atomic_load_explicit(flag, memory_order_seq_cst) == v)
            syscall(SYS_futex, (int *)flag, FUTEX_WAIT_PRIVATE, v, NULL, NULL, 0);
        atomic_fetch_sub_explicit(sleepers, 1, memory_order_seq_cst);
#else
        sched_yield();
#endif
    }
}

static void post(atomic_int *flag, atomic_int *sleepers, int value) {
    atomic_store_explicit(flag, value, memory_order_seq_cst);
#if defined(__linux__)
    if (atomic_load_explicit(sleepers, memory_order_seq_cst) > 0)
        syscall(SYS_futex, (int *)flag, FUTEX_WAKE_PRIVATE, INT_MAX, NULL, NULL, 0);
#endif
}

static void *helper_main(void *arg) {
    helper_t *hp = arg;
    for (int step = 0;; step++) {
        if (wait_for(&hp->go, &hp->sleepers, step + 1) < 0) return NULL;
        const int *cfg = hp->cfg;
        const float *P = hp->units[cfg[C_TIED] ? 0 : hp->guide] + backbone_floats(cfg);
        residual_step(cfg, P, hp->x, hp->M, hp->caches[hp->guide], hp->slot, hp->seen, hp->buf, hp->tr);
        post(&hp->done, &hp->sleepers, step + 1);
    }
}

/* The frame: ln T_hat of every set at its own joint, written to out (n_sets, 3).
 * Inputs and output in float64: norm, the feature mean (8) then std (8); sin_q (n_sets - 1, 4);
 * alpha (n_sets - 1); log_act and out (n_sets, 3).  seen: min(frames already seen, window - 1).
 * threads: 1, or 2 to run g_phi on a helper thread beside f_theta (same result).
 * Returns 0; 2 if two threads were asked for but the helper could not be started, so the
 * frame ran on one (same result); 1 if the scratch memory could not be had. */
int pgchtc_frame(const int *cfg, const float *const *units, const double *norm, float bound, const double *sin_q,
                 const double *alpha, const double *log_act, int slot, int seen, float *const *caches, double *out,
                 int threads) {
    int n = cfg[C_N_SETS], G = cfg[C_N_GUIDES], residual = cfg[C_RESIDUAL];
    int M0 = n - 1;
    size_t part = scratch_floats(cfg, M0);
    float *buf = malloc(sizeof(float) * (2 * part + (size_t)M0 * (8 + 3 + 3)));
    double *log_t = malloc(sizeof(double) * (size_t)M0 * 3);
    if (!buf || !log_t) { free(buf); free(log_t); return 1; }
    float *x = buf + 2 * part, *ratio = x + (size_t)M0 * 8, *tr = ratio + (size_t)M0 * 3;
    helper_t hp = {cfg, units, caches, slot, seen, x, 0, 0, buf + part, tr};
    atomic_init(&hp.go, 0);
    atomic_init(&hp.done, 0);
    atomic_init(&hp.sleepers, 0);
    pthread_t helper;
    int two = residual && threads >= 2 && M0 > 0 && pthread_create(&helper, NULL, helper_main, &hp) == 0;
    memcpy(out, log_act, 3 * sizeof(double)); /* set 1 passes no guide */
    memcpy(log_t, log_act + 3, (size_t)M0 * 3 * sizeof(double));
    int M = M0;
    for (int g = 0; g < G && M > 0; g++) {
        double geo[5] = {sin_q[4 * g], sin_q[4 * g + 1], sin_q[4 * g + 2], sin_q[4 * g + 3], cos(alpha[g])};
        for (int s = 0; s < M; s++) { /* normalised in float64, then rounded (see the header) */
            for (int i = 0; i < 5; i++) x[s * 8 + i] = (float)((geo[i] - norm[i]) / norm[8 + i]);
            for (int i = 0; i < 3; i++) x[s * 8 + 5 + i] = (float)((exp(log_t[s * 3 + i]) - norm[5 + i]) / norm[13 + i]);
        }
        const float *unit = units[cfg[C_TIED] ? 0 : g];
        if (two) {
            hp.guide = g, hp.M = M;
            post(&hp.go, &hp.sleepers, g + 1);
            backbone_step(cfg, unit, x, M, buf, ratio);
            wait_for(&hp.done, &hp.sleepers, g + 1);
        } else {
            backbone_step(cfg, unit, x, M, buf, ratio);
            if (residual) residual_step(cfg, unit + backbone_floats(cfg), x, M, caches[g], slot, seen, buf + part, tr);
        }
        add_log_ratio(ratio, residual ? tr : NULL, M, bound, log_t);
        memcpy(out + 3 * (g + 1), log_t, 3 * sizeof(double)); /* set g + 2 is final after guide g + 1 */
        memmove(log_t, log_t + 3, (size_t)(M - 1) * 3 * sizeof(double));
        M--;
    }
    if (two) {
        post(&hp.go, &hp.sleepers, -1);
        pthread_join(helper, NULL);
    }
    free(buf);
    free(log_t);
    return residual && threads >= 2 && M0 > 0 && !two ? 2 : 0;
}

int pgchtc_cfg_len(void) { return C_LEN; }
