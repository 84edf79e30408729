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
 * compiler maps to the widest SIMD the machine has (streaming_gemm.h, which also reads
 * half-precision copies of the weights where the caller gives them).
 *
 * Two cores: f_theta and g_phi of a guide step read the same unit input and nothing of
 * each other, and cost about the same for the paper preset (0.40 M and 0.39 M multiply-adds
 * per row in their Linear layers), so with threads = 2 a helper thread runs g_phi while the
 * calling thread runs f_theta, meeting once per guide step.  Each part does the same arithmetic in the same
 * order either way, so one and two threads give the same bits.
 *
 * A set has n = cfg[C_N_TENDONS] tendons (the paper's 3): a unit reads n_in = 5 + n inputs per row,
 * [sin q_k (4), cos alpha_k, normalised T (n)], and gives n ratios.
 *
 * Layouts (float32 unless said, C order):
 *   units[u]  : one unit's parameters, in the order the Python packer writes them
 *               (learners/streaming_pack.py, pack_unit).
 *   half_units[u] : optional, the same as binary16 (uint16 bits).
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

#include "streaming_gemm.h"

/* The configuration vector (learners/streaming_native.py, CONFIG_FIELDS, in this order).  C_N_TENDONS came
 * last, so that the other fields kept their places. */
enum { C_N_SETS, C_N_GUIDES, C_TIED, C_N_HIDDEN, C_HIDDEN0, C_RESIDUAL = C_HIDDEN0 + 4, C_D, C_H, C_WINDOW, C_FF, C_LAYERS,
       C_N_TENDONS, C_LEN };

#define N_GEOMETRY 5 /* sin q_k (4), cos alpha_k: the geometric unit inputs of paper Eq. (7) */

static inline int n_inputs(const int *cfg) { return N_GEOMETRY + cfg[C_N_TENDONS]; }

/* erf(x) as a branch-free rational function on VL lanes at once (libm's erff is a scalar call per
 * element: 1.65 against 1.07 ms per frame for the paper preset, with the same agreement with
 * torch's batch inference).  The odd/even polynomials on [-4, 4] are Eigen's
 * generic_fast_erf_float (also XLA's); the test suite bounds its error against torch.erf
 * (3.3e-7 absolute).  Outside [-4, 4], erf is +-1 in float32.  The clamp is a bit select, not
 * a branch, so that the compiler keeps the whole function in vector registers (a scalar clamp
 * blocks the vectoriser: "control flow in loop"); NaN passes through, as in torch. */
typedef int ivec __attribute__((vector_size(VL * sizeof(int))));
static inline vec erf_rational(vec x) {
    vec hi = (vec){0} + 4.f, lo = (vec){0} - 4.f;
    ivec over = x > hi, under = x < lo, bits = (ivec)x;
    bits = (bits & ~over) | ((ivec)hi & over);
    bits = (bits & ~under) | ((ivec)lo & under);
    x = (vec)bits;
    vec x2 = x * x;
    vec p = x2 * -2.72614225801306e-10f + 2.77068142495902e-08f;
    p = x2 * p - 2.10102402082508e-06f;
    p = x2 * p - 5.69250639462346e-05f;
    p = x2 * p - 7.34990630326855e-04f;
    p = x2 * p - 2.95459980854025e-03f;
    p = x2 * p - 1.60960333262415e-02f;
    vec q = x2 * -1.45660718464996e-05f - 2.13374055278905e-04f;
    q = x2 * q - 1.68282697438203e-03f;
    q = x2 * q - 7.37332916720468e-03f;
    q = x2 * q - 1.42647390514189e-02f;
    return x * p / q;
}

/* y = f(x) elementwise, VL lanes at a time; the tail is padded, so every element takes the same path. */
#define MAP_LANES(f, x, y, n)                                              \
    do {                                                                   \
        size_t i_ = 0;                                                     \
        for (; i_ + VL <= (n); i_ += VL) vstore((y) + i_, f(vload((x) + i_))); \
        if (i_ < (n)) {                                                    \
            float t_[VL] = {0};                                            \
            memcpy(t_, (x) + i_, ((n) - i_) * sizeof(float));              \
            vstore(t_, f(vload(t_)));                                      \
            memcpy((y) + i_, t_, ((n) - i_) * sizeof(float));              \
        }                                                                  \
    } while (0)

static inline vec gelu_v(vec x) { return 0.5f * x * (1.0f + erf_rational(x * (float)M_SQRT1_2)); }

static void gelu(float *x, size_t n) { MAP_LANES(gelu_v, x, x, n); } /* exact (erf) GELU, as torch.nn.GELU() */

/* For the tests: the erf the kernel uses. */
void pgchtc_erf(const float *x, float *y, int n) { MAP_LANES(erf_rational, x, y, (size_t)n); }

/* Sums over a row, VL lanes at a time: a scalar loop is one chain of dependent adds, which
 * the compiler may not reorder (IEEE), so it runs at the adder's latency, not its rate.
 * A different order of the same sum: agreement with torch is to float32 rounding, as for
 * the matrix products. */
static inline float hsum(vec v) { /* pairwise: log2(VL) dependent adds, not VL */
    float t[VL];
    memcpy(t, &v, sizeof t);
    for (int w = VL / 2; w >= 1; w /= 2)
        for (int j = 0; j < w; j++) t[j] += t[j + w];
    return t[0];
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
    int w = n_inputs(cfg);
    for (int i = 0; i < cfg[C_N_HIDDEN]; i++) w = cfg[C_HIDDEN0 + i] > w ? cfg[C_HIDDEN0 + i] : w;
    if (3 * cfg[C_D] > w) w = 3 * cfg[C_D];
    return cfg[C_FF] > w ? cfg[C_FF] : w;
}

/* The unit steps come in two copies: one for the paper's n = 3, where the tendon count and the input
 * width are compile-time constants, and one for any n.  Why: how GCC vectorises a Linear layer's sums
 * and which products it fuses into FMAs (-ffp-contract=fast, its default for gnu11) depends on the
 * constants it sees, so a run-time 3 rounds differently in the last bits from the kernel before n was a
 * parameter (measured: 1 880 of 4 320 outputs moved); the constant copy keeps those results bit for bit.
 * Each body is written once (always_inline) and instantiated in both. */
#define ALWAYS_INLINE static inline __attribute__((always_inline))

/* f_theta of a guide step: ln r_MLP (M, nt) into ratio (paper Eq. (8), its first factor).
 * x: the normalised unit inputs (M, n_in) of paper Eq. (7).  buf: 2 * M * widest(cfg) floats. */
ALWAYS_INLINE void backbone_body(const int *cfg, params_t U, const float *x, int M, float *buf, float *ratio, int n_in,
                                 int nt) {
    const float *P = U.f;
    int n_hidden = cfg[C_N_HIDDEN], wide = widest(cfg);
    float *a = buf, *b = buf + (size_t)M * wide;
    /* (Linear [BN folded] -> GELU) per hidden layer, then Linear -> softplus + 0.01 */
    const float *in = x;
    int K = n_in;
    for (int i = 0; i < n_hidden; i++) {
        int N = cfg[C_HIDDEN0 + i];
        float *out = (i % 2) ? b : a;
        linear(in, M, K, U, P, P + (size_t)K * N, N, out);
        P += (size_t)K * N + N;
        gelu(out, (size_t)M * N);
        in = out, K = N;
    }
    linear(in, M, K, U, P, P + (size_t)K * nt, nt, ratio);
    for (int i = 0; i < M * nt; i++) ratio[i] = logf(softplus(ratio[i]) + 0.01f);
}

/* noinline: the calling thread and the helper run the very same machine code, so one and
 * two threads give the same bits whatever the compiler would inline where. */
__attribute__((noinline)) static void backbone_step_3(const int *cfg, params_t U, const float *x, int M, float *buf,
                                                      float *ratio) {
    backbone_body(cfg, U, x, M, buf, ratio, N_GEOMETRY + 3, 3);
}

__attribute__((noinline)) static void backbone_step_n(const int *cfg, params_t U, const float *x, int M, float *buf,
                                                      float *ratio) {
    backbone_body(cfg, U, x, M, buf, ratio, n_inputs(cfg), cfg[C_N_TENDONS]);
}

static void backbone_step(const int *cfg, params_t U, const float *x, int M, float *buf, float *ratio) {
    if (cfg[C_N_TENDONS] == 3)
        backbone_step_3(cfg, U, x, M, buf, ratio);
    else
        backbone_step_n(cfg, U, x, M, buf, ratio);
}

/* g_phi of a guide step: the temporal head's pre-tanh output (M, nt) into tr, reading and
 * updating the guide's ring caches at `slot`.  P: the unit's g_phi parameters, which follow
 * f_theta's (backbone_floats) in a packed unit.
 * buf: M * (2 * widest(cfg) + d_model) floats. */
ALWAYS_INLINE void residual_body(const int *cfg, params_t U, const float *P, const float *x, int M, float *cache, int slot,
                                 int seen, float *buf, float *tr, int n_in, int nt) {
    int wide = widest(cfg);
    int D = cfg[C_D], F = cfg[C_FF], H = cfg[C_H], W = cfg[C_WINDOW];
    float *a = buf, *b = buf + (size_t)M * wide, *h = b + (size_t)M * wide;
    int dk = D / H;
    float scale = 1.0f / sqrtf((float)dk);
    linear(x, M, n_in, U, P, P + (size_t)n_in * D, D, h); /* embed */
    P += (size_t)n_in * D + D;
    for (int l = 0; l < cfg[C_LAYERS]; l++) {
        const float *ln1g = P, *ln1b = P + D, *Wqkv = P + 2 * D, *bqkv = Wqkv + (size_t)D * 3 * D;
        const float *Wo = bqkv + 3 * D, *bo = Wo + (size_t)D * D, *lag_bias = bo + D;
        const float *ln2g = lag_bias + H * W, *ln2b = ln2g + D, *W1 = ln2b + D, *b1 = W1 + (size_t)D * F;
        const float *W2 = b1 + F, *b2 = W2 + (size_t)F * D;
        P = b2 + D;
        float *keys = cache + (size_t)2 * l * M * H * W * dk, *vals = keys + (size_t)M * H * W * dk;
        layer_norm(h, M, D, ln1g, ln1b, a);
        linear(a, M, D, U, Wqkv, bqkv, 3 * D, b); /* q | k | v per row */
        float *att = a; /* (M, D): attention output before the out projection */
        for (int s = 0; s < M; s++)
            for (int hd = 0; hd < H; hd++) {
                const float *q = b + (size_t)s * 3 * D + hd * dk;
                float *K_ = keys + ((size_t)(s * H + hd) * W) * dk, *V_ = vals + ((size_t)(s * H + hd) * W) * dk;
                memcpy(K_ + (size_t)slot * dk, q + D, dk * sizeof(float));
                memcpy(V_ + (size_t)slot * dk, q + 2 * D, dk * sizeof(float));
                float sc[W], mx = -INFINITY;
                for (int w = 0; w < W; w++) {
                    int lag = slot >= w ? slot - w : slot - w + W; /* (slot - w) mod W, without a division */
                    if (lag > seen) { sc[w] = -INFINITY; continue; }
                    sc[w] = dot(q, K_ + (size_t)w * dk, dk) * scale + lag_bias[hd * W + lag];
                    if (sc[w] > mx) mx = sc[w];
                }
                float z = 0.f;
                for (int w = 0; w < W; w++) { sc[w] = sc[w] == -INFINITY ? 0.f : expf(sc[w] - mx); z += sc[w]; }
                float *o = att + (size_t)s * D + hd * dk;
                float inv_z = 1.0f / z; /* one division, not one per lag */
                for (int w = 0; w < W; w++) sc[w] *= inv_z;
                /* o = sum_w p_w V_w, summed over the lags in registers, four vectors of columns at
                 * once so that four chains of dependent FMAs overlap (one chain waits on the FMA's
                 * latency).  Each column's sum runs over the lags in order either way. */
                int i = 0;
                for (; i + 4 * VL <= dk; i += 4 * VL) {
                    vec a0 = {0}, a1 = {0}, a2 = {0}, a3 = {0};
                    for (int w = 0; w < W; w++) {
                        if (sc[w] == 0.f) continue;
                        const float *v = V_ + (size_t)w * dk + i;
                        a0 += sc[w] * vload(v), a1 += sc[w] * vload(v + VL);
                        a2 += sc[w] * vload(v + 2 * VL), a3 += sc[w] * vload(v + 3 * VL);
                    }
                    vstore(o + i, a0), vstore(o + i + VL, a1), vstore(o + i + 2 * VL, a2), vstore(o + i + 3 * VL, a3);
                }
                for (; i + VL <= dk; i += VL) {
                    vec acc = {0};
                    for (int w = 0; w < W; w++)
                        if (sc[w] != 0.f) acc += sc[w] * vload(V_ + (size_t)w * dk + i);
                    vstore(o + i, acc);
                }
                for (; i < dk; i++) {
                    float acc = 0.f;
                    for (int w = 0; w < W; w++)
                        if (sc[w] != 0.f) acc += sc[w] * V_[(size_t)w * dk + i];
                    o[i] = acc;
                }
            }
        linear(att, M, D, U, Wo, bo, D, b);
        for (size_t i = 0; i < (size_t)M * D; i++) h[i] += b[i];
        layer_norm(h, M, D, ln2g, ln2b, a);
        linear(a, M, D, U, W1, b1, F, b);
        gelu(b, (size_t)M * F);
        linear(b, M, F, U, W2, b2, D, a);
        for (size_t i = 0; i < (size_t)M * D; i++) h[i] += a[i];
    }
    layer_norm(h, M, D, P, P + D, a);
    P += 2 * D;
    linear(a, M, D, U, P, P + (size_t)D * nt, nt, tr);
}

__attribute__((noinline)) static void residual_step_3(const int *cfg, params_t U, const float *P, const float *x, int M,
                                                      float *cache, int slot, int seen, float *buf, float *tr) {
    residual_body(cfg, U, P, x, M, cache, slot, seen, buf, tr, N_GEOMETRY + 3, 3);
}

__attribute__((noinline)) static void residual_step_n(const int *cfg, params_t U, const float *P, const float *x, int M,
                                                      float *cache, int slot, int seen, float *buf, float *tr) {
    residual_body(cfg, U, P, x, M, cache, slot, seen, buf, tr, n_inputs(cfg), cfg[C_N_TENDONS]);
}

static void residual_step(const int *cfg, params_t U, const float *P, const float *x, int M, float *cache, int slot,
                          int seen, float *buf, float *tr) {
    if (cfg[C_N_TENDONS] == 3)
        residual_step_3(cfg, U, P, x, M, cache, slot, seen, buf, tr);
    else
        residual_step_n(cfg, U, P, x, M, cache, slot, seen, buf, tr);
}

/* ln r = clamp(ln r_MLP + ln(1 + 0.5 tanh(tr))) (paper Eq. (8)), added to log_t (M, n, float64). */
static void add_log_ratio(const float *ratio, const float *tr, int M, int nt, float bound, double *log_t) {
    for (int i = 0; i < M * nt; i++) {
        float v = tr ? ratio[i] + log1pf(0.5f * tanhf(tr[i])) : ratio[i];
        v = v < -bound ? -bound : (v > bound ? bound : v);
        log_t[i] += (double)v;
    }
}

/* Size in floats of the scratch buffer one part of a guide step (backbone_step or residual_step) needs for M streams. */
static size_t scratch_floats(const int *cfg, int M) { return (size_t)M * (2 * widest(cfg) + cfg[C_D]) + 64; }

/* Floats of f_theta's parameters, at the start of a packed unit. */
static long backbone_floats(const int *cfg) {
    long n = 0, K = n_inputs(cfg), nt = cfg[C_N_TENDONS];
    for (int i = 0; i < cfg[C_N_HIDDEN]; i++) n += K * cfg[C_HIDDEN0 + i] + cfg[C_HIDDEN0 + i], K = cfg[C_HIDDEN0 + i];
    return n + K * nt + nt;
}

/* Floats in one unit's packed parameters (the Python packer checks its layout against this). */
long pgchtc_unit_floats(const int *cfg) {
    long n = backbone_floats(cfg), D = cfg[C_D], F = cfg[C_FF], H = cfg[C_H], W = cfg[C_WINDOW];
    long n_in = n_inputs(cfg), nt = cfg[C_N_TENDONS];
    if (cfg[C_RESIDUAL])
        n += n_in * D + D + cfg[C_LAYERS] * (2 * D + D * 3 * D + 3 * D + D * D + D + H * W + 2 * D + D * F + F + F * D + D) + 2 * D + D * nt + nt;
    return n;
}

/* Floats in guide g's ring caches: keys and values of every layer for its n_sets - 1 - g streams. */
long pgchtc_cache_floats(const int *cfg, int g) {
    if (!cfg[C_RESIDUAL]) return 0;
    return 2L * cfg[C_LAYERS] * (cfg[C_N_SETS] - 1 - g) * cfg[C_WINDOW] * cfg[C_D];
}

/* The g_phi helper thread: started once per engine (pgchtc_helper_new) and ended by
 * pgchtc_helper_free, so that a frame pays no thread start.  Guide steps are numbered across
 * frames (unsigned, wrapping): a step is posted when `go` reaches its number and finished when
 * `done` does; `quit` ends the thread.  The frame fields are written by the calling thread
 * before it posts a step, and read by the helper after it sees the post (seq_cst). */
typedef struct {
    const int *cfg;
    const float *const *units;
    const uint16_t *const *half_units; /* NULL: float32 weights */
    float *const *caches;
    int slot, seen;
    const float *x; /* the posted guide's unit inputs */
    int guide, M;
    float *buf, *tr;
    unsigned seq; /* the last step posted; the calling thread's alone */
    atomic_uint go, done;
    atomic_int quit;
    atomic_int sleepers; /* threads blocked (or about to block) in wait_for */
    pthread_t thread;
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

/* Waits until *flag == value (returns 0) or, with quit given, until *quit is set (returns -1). */
static int wait_for(atomic_uint *flag, atomic_int *sleepers, unsigned value, atomic_int *quit) {
    for (unsigned spins = 0;; spins++) {
        unsigned v = atomic_load_explicit(flag, memory_order_seq_cst);
        /* quit is read after the flag: pgchtc_helper_free sets it before it changes the flag */
        if (quit && atomic_load_explicit(quit, memory_order_seq_cst)) return -1;
        if (v == value) return 0;
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

static void post(atomic_uint *flag, atomic_int *sleepers, unsigned value) {
    atomic_store_explicit(flag, value, memory_order_seq_cst);
#if defined(__linux__)
    if (atomic_load_explicit(sleepers, memory_order_seq_cst) > 0)
        syscall(SYS_futex, (int *)flag, FUTEX_WAKE_PRIVATE, INT_MAX, NULL, NULL, 0);
#endif
}

/* Guide g's unit: its float32 parameters and, where given, their binary16 copy. */
static params_t unit_params(const int *cfg, const float *const *units, const uint16_t *const *half_units, int g) {
    int u = cfg[C_TIED] ? 0 : g;
    return (params_t){units[u], half_units ? half_units[u] : NULL};
}

static void *helper_main(void *arg) {
    helper_t *hp = arg;
    for (unsigned step = 1;; step++) {
        if (wait_for(&hp->go, &hp->sleepers, step, &hp->quit) < 0) return NULL;
        const int *cfg = hp->cfg;
        params_t U = unit_params(cfg, hp->units, hp->half_units, hp->guide);
        residual_step(cfg, U, U.f + backbone_floats(cfg), hp->x, hp->M, hp->caches[hp->guide], hp->slot, hp->seen,
                      hp->buf, hp->tr);
        post(&hp->done, &hp->sleepers, step);
    }
}

/* A helper thread for pgchtc_frame's threads = 2, or NULL if it cannot be started. */
void *pgchtc_helper_new(void) {
    helper_t *hp = calloc(1, sizeof *hp);
    if (!hp) return NULL;
    atomic_init(&hp->go, 0);
    atomic_init(&hp->done, 0);
    atomic_init(&hp->quit, 0);
    atomic_init(&hp->sleepers, 0);
    if (pthread_create(&hp->thread, NULL, helper_main, hp) != 0) {
        free(hp);
        return NULL;
    }
    return hp;
}

/* Ends the helper thread and frees it.  Not while a frame runs on it. */
void pgchtc_helper_free(void *helper) {
    helper_t *hp = helper;
    if (!hp) return;
    atomic_store_explicit(&hp->quit, 1, memory_order_seq_cst);
    /* change the flag it may sleep on, so that its futex wait cannot miss the wake-up */
    atomic_fetch_add_explicit(&hp->go, 0x80000000u, memory_order_seq_cst);
#if defined(__linux__)
    syscall(SYS_futex, (int *)&hp->go, FUTEX_WAKE_PRIVATE, INT_MAX, NULL, NULL, 0);
#endif
    pthread_join(hp->thread, NULL);
    free(hp);
}

/* The frame: ln T_hat of every set at its own joint, written to out (n_sets, n).
 * Inputs and output in float64: norm, the feature mean (n_in) then std (n_in); sin_q (n_sets - 1, 4);
 * alpha (n_sets - 1); log_act and out (n_sets, n).  seen: min(frames already seen, window - 1).
 * threads: 1, or 2 to run g_phi on the helper thread (pgchtc_helper_new) beside f_theta (same result).
 * half_units: NULL, or per unit a binary16 copy of units[u] whose matrices the products read
 * (streaming_gemm.h says why).
 * Returns 0; 2 if two threads were asked for without a helper, so the frame ran on one (same
 * result); 1 if the scratch memory could not be had. */
int pgchtc_frame(const int *cfg, const float *const *units, const uint16_t *const *half_units, const double *norm, float bound, const double *sin_q,
                 const double *alpha, const double *log_act, int slot, int seen, float *const *caches, double *out,
                 int threads, void *helper) {
    int n = cfg[C_N_SETS], G = cfg[C_N_GUIDES], residual = cfg[C_RESIDUAL], nt = cfg[C_N_TENDONS], n_in = n_inputs(cfg);
    int M0 = n - 1;
    size_t part = scratch_floats(cfg, M0);
    float *buf = malloc(sizeof(float) * (2 * part + (size_t)M0 * (n_in + nt + nt)));
    double *log_t = malloc(sizeof(double) * (size_t)M0 * nt);
    if (!buf || !log_t) { free(buf); free(log_t); return 1; }
    float *x = buf + 2 * part, *ratio = x + (size_t)M0 * n_in, *tr = ratio + (size_t)M0 * nt;
    helper_t *hp = helper;
    int two = residual && threads >= 2 && M0 > 0 && hp;
    if (two) {
        hp->cfg = cfg, hp->units = units, hp->half_units = half_units, hp->caches = caches;
        hp->slot = slot, hp->seen = seen, hp->x = x, hp->buf = buf + part, hp->tr = tr;
    }
    memcpy(out, log_act, nt * sizeof(double)); /* set 1 passes no guide */
    memcpy(log_t, log_act + nt, (size_t)M0 * nt * sizeof(double));
    int M = M0;
    for (int g = 0; g < G && M > 0; g++) {
        double geo[N_GEOMETRY] = {sin_q[4 * g], sin_q[4 * g + 1], sin_q[4 * g + 2], sin_q[4 * g + 3], cos(alpha[g])};
        for (int s = 0; s < M; s++) { /* normalised in float64, then rounded (see the header) */
            float *xs = x + (size_t)s * n_in;
            for (int i = 0; i < N_GEOMETRY; i++) xs[i] = (float)((geo[i] - norm[i]) / norm[n_in + i]);
            for (int i = 0; i < nt; i++)
                xs[N_GEOMETRY + i] =
                    (float)((exp(log_t[s * nt + i]) - norm[N_GEOMETRY + i]) / norm[n_in + N_GEOMETRY + i]);
        }
        params_t unit = unit_params(cfg, units, half_units, g);
        if (two) {
            hp->guide = g, hp->M = M;
            unsigned step = ++hp->seq;
            post(&hp->go, &hp->sleepers, step);
            backbone_step(cfg, unit, x, M, buf, ratio);
            wait_for(&hp->done, &hp->sleepers, step, NULL);
        } else {
            backbone_step(cfg, unit, x, M, buf, ratio);
            if (residual) residual_step(cfg, unit, unit.f + backbone_floats(cfg), x, M, caches[g], slot, seen, buf + part, tr);
        }
        add_log_ratio(ratio, residual ? tr : NULL, M, nt, bound, log_t);
        memcpy(out + (size_t)nt * (g + 1), log_t, nt * sizeof(double)); /* set g + 2 is final after guide g + 1 */
        memmove(log_t, log_t + nt, (size_t)(M - 1) * nt * sizeof(double));
        M--;
    }
    free(buf);
    free(log_t);
    return residual && threads >= 2 && M0 > 0 && !two ? 2 : 0;
}

int pgchtc_cfg_len(void) { return C_LEN; }
