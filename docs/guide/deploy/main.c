/* main.c: stream a recording (CSV, as tendon-id writes it) through an exported model; print its tensions.
 *
 * Build it beside an export (tendon-id export MODEL --format c --out model-c):
 *     cc -O2 -I model-c -o stream main.c model-c/tendon_model.c -lm
 * and run it:
 *     ./stream recording.csv > tensions.csv
 *
 * The recording needs the columns theta_K_x and theta_K_y (K = 1..N) [rad] and tension_act_J_I
 * (J = 1..N, I = 1..m) [N]; a trajectory column, if there is one, starts each trajectory from a
 * reset state; other columns are ignored.  Fields are plain: no quotes, no commas inside them.
 * Output: one line per frame, the trajectory, the frame within it, then the joint-side
 * estimates tension_hat_J_I [N].  Exit codes: 0 ok, 2 a bad file, 1 a frame the model refuses.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tendon_model.h"

#define N TENDON_MODEL_N_MODULES
#define M TENDON_MODEL_N_TENDONS
#define LINE 65536
#define MAX_COLUMNS 4096

/* Split a CSV line in place at its commas; returns the number of fields. */
static int split(char *line, char **fields) {
    int n = 0;
    line[strcspn(line, "\r\n")] = '\0';
    for (char *p = line; n < MAX_COLUMNS;) {
        fields[n++] = p;
        char *comma = strchr(p, ',');
        if (!comma) break;
        *comma = '\0';
        p = comma + 1;
    }
    return n;
}

static int column(char **names, int count, const char *name) {
    for (int c = 0; c < count; c++)
        if (strcmp(names[c], name) == 0) return c;
    return -1;
}

/* A field as a number; 0 if it is not one. */
static int number(const char *field, double *value) {
    char *end;
    *value = strtod(field, &end);
    return end != field && *end == '\0';
}

int main(int argc, char **argv) {
    static char header[LINE], line[LINE];
    static char *names[MAX_COLUMNS], *fields[MAX_COLUMNS];
    static tendon_model_state state; /* static: for a large model it is too big for the stack */
    int angle_col[N][2], tension_col[N][M];
    double angles[N * 2], actuator[N * M], tensions[N * M];
    char name[64], trajectory[256] = "";

    if (argc != 2) {
        fprintf(stderr, "usage: %s RECORDING.csv\n", argv[0]);
        return 2;
    }
    FILE *in = fopen(argv[1], "r");
    if (!in || !fgets(header, sizeof header, in)) {
        fprintf(stderr, "%s: cannot read a header line\n", argv[1]);
        return 2;
    }
    int count = split(header, names);
    int trajectory_col = column(names, count, "trajectory");
    for (int k = 0; k < N; k++)
        for (int a = 0; a < 2; a++) {
            snprintf(name, sizeof name, "theta_%d_%c", k + 1, "xy"[a]);
            if ((angle_col[k][a] = column(names, count, name)) < 0) {
                fprintf(stderr, "%s: no column %s (the model has %d modules)\n", argv[1], name, N);
                return 2;
            }
        }
    for (int j = 0; j < N; j++)
        for (int i = 0; i < M; i++) {
            snprintf(name, sizeof name, "tension_act_%d_%d", j + 1, i + 1);
            if ((tension_col[j][i] = column(names, count, name)) < 0) {
                fprintf(stderr, "%s: no column %s (the model has %d tendons per set)\n", argv[1], name, M);
                return 2;
            }
        }

    printf("trajectory,frame");
    for (int j = 0; j < N; j++)
        for (int i = 0; i < M; i++) printf(",tension_hat_%d_%d", j + 1, i + 1);
    printf("\n");

    tendon_model_init(&state);
    long row = 1, frame = 0;
    while (fgets(line, sizeof line, in)) {
        row++;
        if (!strchr(line, '\n') && !feof(in)) {
            fprintf(stderr, "%s: row %ld is longer than %d characters\n", argv[1], row, LINE - 1);
            return 2;
        }
        if (split(line, fields) != count) {
            fprintf(stderr, "%s: row %ld does not have the header's %d fields\n", argv[1], row, count);
            return 2;
        }
        const char *id = trajectory_col >= 0 ? fields[trajectory_col] : "";
        if (row == 2 || strncmp(id, trajectory, sizeof trajectory - 1) != 0) { /* a new trajectory */
            tendon_model_reset(&state);
            frame = 0;
            snprintf(trajectory, sizeof trajectory, "%s", id);
        }
        int ok = 1;
        for (int k = 0; k < N; k++)
            for (int a = 0; a < 2; a++) ok &= number(fields[angle_col[k][a]], &angles[2 * k + a]);
        for (int j = 0; j < N; j++)
            for (int i = 0; i < M; i++) ok &= number(fields[tension_col[j][i]], &actuator[j * M + i]);
        if (!ok) {
            fprintf(stderr, "%s: row %ld: an angle or tension is not a number\n", argv[1], row);
            return 2;
        }
        if (tendon_model_step(&state, angles, actuator, tensions)) {
            fprintf(stderr, "%s: row %ld: a value is not finite or a tension is not > 0\n", argv[1], row);
            return 1;
        }
        printf("%s,%ld", trajectory, frame++);
        for (int c = 0; c < N * M; c++) printf(",%.17g", tensions[c]);
        printf("\n");
    }
    fclose(in);
    return 0;
}
