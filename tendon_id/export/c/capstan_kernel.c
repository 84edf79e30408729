/* ---- the streaming step of a capstan law (tendon-id export: tendon_id/export/c/capstan_kernel.c) ----
 *
 * The same arithmetic, in float64 and in the same order, as the model's blocks in tendon-id
 * (tendon_id.zoo.chain, tendon_id.zoo.capstan_stream.CapstanStream):
 *   alpha_k = min(min(|theta_k| / 2 + |theta_{k+1}| / 2, pi) + ALPHA_0, pi)       paper Eq. (3)
 *   alpha_eff = alpha * max(alpha - ALPHA_C, 0) / alpha  or  alpha * 1[alpha > ALPHA_C]  (gate)
 *   phi = (A cos(alpha) + B) * alpha_eff   (B * alpha_eff for a constant mu)   paper Eqs. (4)-(6)
 *   through each guide: lo, hi = x -/+ phi;  y = clamp(y_prev, lo, hi) with hysteresis, else lo,
 *   and y = lo on a trajectory's first frame (the tendon has just been pulled taut).
 * The prelude above defines NM (modules), NT (tendons per set), NG = NM - 1 (guides), LAW_ROWS
 * (1: tied, else NG), LAW_A, LAW_B, ALPHA_0, GATE (0 none, 1 dead zone, 2 hard), ALPHA_C,
 * HYSTERESIS, CONSTANT_MU and the state type state_t, with fields n_seen and (with
 * hysteresis) play_y[NG][NM][NT]. */

static const double PI_ = 3.141592653589793;

static void state_reset(state_t *s) { memset(s, 0, sizeof *s); }

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
    double mag[NM], phi[NG][NT], x[NM][NT];
    for (int k = 0; k < NM; k++) mag[k] = sqrt(angles[2 * k] * angles[2 * k] + angles[2 * k + 1] * angles[2 * k + 1]);
    for (int g = 0; g < NG; g++) {
        double bend = 0.5 * mag[g] + 0.5 * mag[g + 1];
        bend = bend < PI_ ? bend : PI_;
        double alpha = bend + ALPHA_0;
        alpha = alpha < PI_ ? alpha : PI_;
        double scaled = alpha;
#if GATE == 1
        double pressed = alpha - ALPHA_C > 0.0 ? alpha - ALPHA_C : 0.0;
        scaled = alpha * (alpha > 0.0 ? pressed / alpha : 0.0);
#elif GATE == 2
        scaled = alpha * (alpha > ALPHA_C ? 1.0 : 0.0);
#endif
        int row = LAW_ROWS == 1 ? 0 : g;
        for (int i = 0; i < NT; i++) {
#if CONSTANT_MU
            phi[g][i] = LAW_B[row][i] * scaled;
#else
            phi[g][i] = (LAW_A[row][i] * cos(alpha) + LAW_B[row][i]) * scaled;
#endif
        }
    }
    for (int j = 0; j < NM; j++)
        for (int i = 0; i < NT; i++) x[j][i] = log(actuator[j * NT + i]);
    for (int i = 0; i < NT; i++) tensions[i] = actuator[i]; /* set 1 passes no guide: its reading, exactly */
    for (int j = 1; j < NM; j++) {                          /* set j + 1 passes guides 1..j */
        for (int i = 0; i < NT; i++) {
            double v = x[j][i];
            for (int g = 0; g < j; g++) {
                double lo = v - phi[g][i];
#if HYSTERESIS
                double hi = v + phi[g][i];
                if (s->n_seen > 0) {
                    double y = s->play_y[g][j][i];
                    y = y > lo ? y : lo;
                    v = y < hi ? y : hi;
                } else {
                    v = lo;
                }
                s->play_y[g][j][i] = v;
#else
                v = lo;
#endif
            }
            tensions[j * NT + i] = exp(v);
        }
    }
    s->n_seen = 1;
    return 0;
}
