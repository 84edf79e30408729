/* ---- the streaming step of PG-CHTC (tendon-id export: tendon_id/export/c/cascade_kernel.c) ----
 *
 * The frame of learners.cascade.StreamingCascade (paper Algorithm 1), as tendon-id's own C
 * kernel (learners/streaming_kernel.c) computes it, in portable C99 without SIMD extensions:
 * the unit inputs of paper Eq. (7) normalised in float64, then per guide f_theta (BatchNorm
 * folded into its Linear layers) and the causal Transformer g_phi over a ring cache of the
 * last WIN frames, in float32, and ln T += clamp(ln r_MLP + ln(1 + 0.5 tanh(g_phi))) summed in
 * float64.  Only the order of the float32 sums differs from torch's, so results agree to float32
 * rounding of the units, amplified along the chain as in any float32 run of the cascade.
 *
 * The prelude defines the sizes (NM modules, NT tendons per set, NF = 5 + NT unit inputs,
 * NG = NM - 1 guides, N_HIDDEN, RESIDUAL, DM, NHEAD, DK = DM / NHEAD, WIN, DFF, NLAYER,
 * N_UNITS, NSTREAMS = NG (NG + 1) / 2, WIDEST, CACHE_FLOATS), NORM_MEAN, NORM_STD, ALPHA_0,
 * LOG_RATIO_BOUND and the state type state_t (n_seen, slot, cache, scratch). */

typedef struct { const float *w, *b; int in, out; } linear_t; /* y = x @ w + b; w is (in, out), row-major */
typedef struct { const float *g, *b; } norm_t;                 /* LayerNorm's weight and bias, eps 1e-5 */
typedef struct {
    norm_t ln1;
    linear_t qkv, out;
    const float *lag_bias; /* (NHEAD, WIN): bias[h][lag] */
    norm_t ln2;
    linear_t ff1, ff2;
} layer_t;
typedef struct {
    linear_t backbone[N_HIDDEN + 1]; /* hidden layers, then the head */
    linear_t embed;
    layer_t layers[NLAYER > 0 ? NLAYER : 1];
    norm_t norm;
    linear_t head;
} unit_t;

@WEIGHTS@

static const double PI_ = 3.141592653589793;
/* keys, then values: [layer][stream][head][slot][channel]; guide g's streams start at g NG - g (g - 1) / 2 */
#define KEY(l, s, h) (((size_t)((l) * NSTREAMS + (s)) * NHEAD + (h)) * WIN * DK)
#define VALUES_AT ((size_t)NLAYER * NSTREAMS * NHEAD * WIN * DK)

static float gelu_f(float x) { return x * 0.5f * (1.0f + erff(x * 0.70710678118654752440f)); } /* exact GELU */
static float softplus_f(float x) { return x > 20.0f ? x : log1pf(expf(x)); }                   /* torch's threshold */

/* y (M, out) = x (M, in) @ w + b.  Each weight row is read once for all M rows, from the cache, and each
 * output sums over k in order.  Why the 8-wide inner blocks: their fixed trip count lets a compiler at -O2
 * turn them into SIMD instructions (GCC's cost model there vectorises no loop of unknown length), with no
 * intrinsics, so the source stays portable C99. */
static void linear(const float *restrict x, int M, linear_t L, float *restrict y) {
    const int N = L.out, K = L.in, n8 = N - N % 8;
    for (int m = 0; m < M; m++) memcpy(y + (size_t)m * N, L.b, (size_t)N * sizeof(float));
    for (int k = 0; k < K; k++) {
        const float *restrict w = L.w + (size_t)k * N;
        for (int m = 0; m < M; m++) {
            const float a = x[(size_t)m * K + k];
            float *restrict ym = y + (size_t)m * N;
            int n = 0;
            for (; n < n8; n += 8)
                for (int j = 0; j < 8; j++) ym[n + j] += a * w[n + j];
            for (; n < N; n++) ym[n] += a * w[n];
        }
    }
}

#if RESIDUAL
static void layer_norm(const float *x, int M, int D, norm_t p, float *y) {
    for (int m = 0; m < M; m++) {
        const float *r = x + (size_t)m * D;
        float mean = 0.f, var = 0.f;
        for (int i = 0; i < D; i++) mean += r[i];
        mean /= D;
        for (int i = 0; i < D; i++) var += (r[i] - mean) * (r[i] - mean);
        float inv = 1.0f / sqrtf(var / D + 1e-5f);
        for (int i = 0; i < D; i++) y[(size_t)m * D + i] = (r[i] - mean) * inv * p.g[i] + p.b[i];
    }
}

#endif

static void state_reset(state_t *s) {
    s->n_seen = 0;
    s->slot = 0;
    memset(s->cache, 0, sizeof s->cache); /* masked until written, but kept finite: 0 * NaN is NaN */
}

#if RESIDUAL
/* g_phi of guide step rows x (M, NF) into tr (M, NT), writing the frame's keys and values at the ring's slot. */
static void residual_step(state_t *s, const unit_t *u, const float *x, int M, int first_stream, float *tr) {
    float *a = s->scratch + (size_t)(NG)*NF, *b = a + (size_t)NG * WIDEST, *e = b + (size_t)NG * WIDEST;
    int slot = s->slot, seen = s->n_seen < WIN - 1 ? s->n_seen : WIN - 1;
    float scale = sqrtf((float)DK);
    linear(x, M, u->embed, e);
    for (int l = 0; l < NLAYER; l++) {
        const layer_t *L = &u->layers[l];
        layer_norm(e, M, DM, L->ln1, a);
        linear(a, M, L->qkv, b); /* q | k | v per row */
        for (int r = 0; r < M; r++)
            for (int h = 0; h < NHEAD; h++) {
                const float *q = b + (size_t)r * 3 * DM + h * DK;
                float *K = s->cache + KEY(l, first_stream + r, h), *V = K + VALUES_AT;
                memcpy(K + (size_t)slot * DK, q + DM, DK * sizeof(float));
                memcpy(V + (size_t)slot * DK, q + 2 * DM, DK * sizeof(float));
                float sc[WIN], top = -INFINITY, z = 0.f;
                for (int w = 0; w < WIN; w++) {
                    int lag = slot >= w ? slot - w : slot - w + WIN;
                    if (lag > seen) { sc[w] = -INFINITY; continue; } /* no frame of this trajectory there yet */
                    float dot = 0.f;
                    for (int c = 0; c < DK; c++) dot += q[c] * K[(size_t)w * DK + c];
                    sc[w] = dot / scale + L->lag_bias[h * WIN + lag];
                    if (sc[w] > top) top = sc[w];
                }
                for (int w = 0; w < WIN; w++) {
                    sc[w] = sc[w] == -INFINITY ? 0.f : expf(sc[w] - top);
                    z += sc[w];
                }
                float *o = a + (size_t)r * DM + h * DK; /* a is free once q, k, v are in b */
                for (int c = 0; c < DK; c++) o[c] = 0.f;
                for (int w = 0; w < WIN; w++) {
                    if (sc[w] == 0.f) continue;
                    float p = sc[w] / z;
                    for (int c = 0; c < DK; c++) o[c] += p * V[(size_t)w * DK + c];
                }
            }
        linear(a, M, L->out, b);
        for (size_t i = 0; i < (size_t)M * DM; i++) e[i] += b[i];
        layer_norm(e, M, DM, L->ln2, a);
        linear(a, M, L->ff1, b);
        for (size_t i = 0; i < (size_t)M * DFF; i++) b[i] = gelu_f(b[i]);
        linear(b, M, L->ff2, a);
        for (size_t i = 0; i < (size_t)M * DM; i++) e[i] += a[i];
    }
    layer_norm(e, M, DM, u->norm, a);
    linear(a, M, u->head, tr);
}
#endif

/* 0 if every angle is finite and every actuator tension finite and > 0. */
static int check_frame(const double *angles, const double *actuator) {
    for (int i = 0; i < 2 * NM; i++)
        if (!isfinite(angles[i])) return 1;
    for (int i = 0; i < NM * NT; i++)
        if (!isfinite(actuator[i]) || !(actuator[i] > 0.0)) return 1;
    return 0;
}

static int state_step(state_t *s, const double *angles, const double *actuator, double *tensions) {
    if (check_frame(angles, actuator)) return 1;
    float *x = s->scratch, *a = x + (size_t)NG * NF, *b = a + (size_t)NG * WIDEST;
    float *ratio = b + (size_t)NG * WIDEST + (size_t)NG * DM;
#if RESIDUAL
    float *tr = ratio + (size_t)NG * NT;
    int first_stream = 0; /* guide g's caches start at stream sum_{h < g} (NG - h) */
#endif
    double mag[NM], geo[NG][5], log_t[NM][NT];
    for (int k = 0; k < NM; k++) mag[k] = sqrt(angles[2 * k] * angles[2 * k] + angles[2 * k + 1] * angles[2 * k + 1]);
    for (int g = 0; g < NG; g++) { /* paper Eqs. (2), (3): sin q_k and the backbone wrap */
        double alpha = 0.5 * mag[g] + 0.5 * mag[g + 1] + ALPHA_0;
        alpha = alpha < PI_ ? alpha : PI_;
        geo[g][0] = sin(angles[2 * g]), geo[g][1] = sin(angles[2 * g + 1]);
        geo[g][2] = sin(angles[2 * g + 2]), geo[g][3] = sin(angles[2 * g + 3]);
        geo[g][4] = cos(alpha);
    }
    for (int j = 0; j < NM; j++)
        for (int i = 0; i < NT; i++) log_t[j][i] = log(actuator[j * NT + i]);
    for (int i = 0; i < NT; i++) tensions[i] = actuator[i]; /* set 1 passes no guide: its reading, exactly */
    for (int g = 0; g < NG; g++) {
        int M = NG - g; /* sets g + 2 .. NM pass guide g + 1 */
        const unit_t *u = &UNITS[N_UNITS == 1 ? 0 : g];
        for (int r = 0; r < M; r++) { /* normalised in float64, then rounded (learners.cascade says why) */
            for (int i = 0; i < 5; i++) x[r * NF + i] = (float)((geo[g][i] - NORM_MEAN[i]) / NORM_STD[i]);
            for (int i = 0; i < NT; i++)
                x[r * NF + 5 + i] = (float)((exp(log_t[g + 1 + r][i]) - NORM_MEAN[5 + i]) / NORM_STD[5 + i]);
        }
        const float *in = x;
        for (int l = 0; l < N_HIDDEN; l++) {
            float *out = (l % 2) ? b : a;
            linear(in, M, u->backbone[l], out);
            for (size_t i = 0; i < (size_t)M * u->backbone[l].out; i++) out[i] = gelu_f(out[i]);
            in = out;
        }
        linear(in, M, u->backbone[N_HIDDEN], ratio);
        for (int i = 0; i < M * NT; i++) ratio[i] = logf(softplus_f(ratio[i]) + 0.01f);
#if RESIDUAL
        residual_step(s, u, x, M, first_stream, tr);
#endif
        for (int r = 0; r < M; r++)
            for (int i = 0; i < NT; i++) {
                float v = ratio[r * NT + i];
#if RESIDUAL
                v += log1pf(0.5f * tanhf(tr[r * NT + i]));
#endif
                v = v < -LOG_RATIO_BOUND ? -LOG_RATIO_BOUND : (v > LOG_RATIO_BOUND ? LOG_RATIO_BOUND : v);
                log_t[g + 1 + r][i] += (double)v;
            }
        for (int i = 0; i < NT; i++) tensions[(g + 1) * NT + i] = exp(log_t[g + 1][i]); /* set g + 2 is final */
#if RESIDUAL
        first_stream += M;
#endif
    }
    s->slot = s->slot + 1 < WIN ? s->slot + 1 : 0;
    s->n_seen = s->n_seen < WIN ? s->n_seen + 1 : WIN;
    return 0;
}
