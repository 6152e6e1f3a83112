/*
 * The dynamic scheduler from C, with thresholds that split vertex groups at every chance,
 * against the classic scheduler on the same seed: the maps must agree to 1e-12. Small
 * enough to run under a race detector:
 *
 *   valgrind --tool=helgrind build/c_tests/threaded_splits 3000
 *   valgrind --tool=drd      build/c_tests/threaded_splits 3000
 */
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N 40 /* grid cells per side */

static double xyz[3 * (N + 1) * (N + 1)];
static uint32_t idx[6 * N * N];

/* Runs `photons` photons on a lit grid with the given scheduler settings; returns the
 * green-band map (caller frees) and the report. */
static double *run(const ImapConfig *cfg, uint64_t photons, ImapReport *rep) {
    ImapContext *ctx = NULL;
    if (imap_create(cfg, &ctx) != IMAP_OK) {
        fprintf(stderr, "imap_create: %s\n", imap_last_error(NULL));
        exit(1);
    }
    double grey = 0.6, pos[3] = {0.3 * N, 0.6 * N, 4}, below[3] = {0.7 * N, 0.4 * N, -4}, watts = 100;
    uint32_t mat, mesh, light;
    ImapMaterial m;
    imap_material_default(&m, sizeof m);
    m.diffuse_reflectance = &grey, m.diffuse_reflectance_count = 1;
    ImapMesh d;
    imap_mesh_default(&d, sizeof d);
    d.positions = xyz, d.vertex_count = (N + 1) * (N + 1), d.indices = idx, d.triangle_count = 2 * N * N;
    d.flags = IMAP_MESH_RECORD | IMAP_MESH_TWO_SIDED;
    ImapRunParams p;
    imap_run_params_default(&p, sizeof p);
    p.photons = photons;
    if (imap_add_material(ctx, &m, &mat) || (d.material = mat, imap_add_mesh(ctx, &d, &mesh)) ||
        imap_add_point_light(ctx, pos, &watts, 1, &light) || imap_add_point_light(ctx, below, &watts, 1, &light) ||
        imap_run(ctx, &p, rep, sizeof *rep)) {
        fprintf(stderr, "setup or run failed: %s\n", imap_last_error(ctx));
        exit(1);
    }
    double *e = malloc(2 * d.vertex_count * sizeof(double));
    imap_get_vertex_energy(ctx, mesh, IMAP_SIDE_FRONT, 1, e, d.vertex_count);
    imap_get_vertex_energy(ctx, mesh, IMAP_SIDE_BACK, 1, e + d.vertex_count, d.vertex_count);
    imap_destroy(ctx);
    return e;
}

int main(int argc, char **argv) {
    uint64_t photons = argc > 1 ? strtoull(argv[1], NULL, 10) : 200000;
    /* A wavy grid lit from above and below. */
    for (int j = 0; j <= N; j++)
        for (int i = 0; i <= N; i++) {
            double *p = xyz + 3 * (j * (N + 1) + i);
            p[0] = i, p[1] = j, p[2] = 1.5 * sin(0.4 * i) * cos(0.3 * j);
        }
    uint32_t *t = idx;
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            uint32_t a = j * (N + 1) + i, b = a + 1, c = a + N + 2, e = a + N + 1;
            *t++ = a, *t++ = b, *t++ = c, *t++ = a, *t++ = c, *t++ = e;
        }

    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2, cfg.seed = 99, cfg.band_mode = IMAP_BANDS_SPECTRAL, cfg.band_count = 16;
    cfg.scheduler = IMAP_SCHEDULER_CLASSIC;
    ImapReport rc, rd;
    double *classic = run(&cfg, photons, &rc);
    /* Split whenever a group has a queued portion, down to single vertex sides. */
    cfg.scheduler = IMAP_SCHEDULER_DYNAMIC;
    cfg.initial_groups = 1, cfg.max_groups = 2048, cfg.min_group_slots = 1;
    cfg.split_low_threshold = UINT32_MAX, cfg.split_high_threshold = 1;
    double *dynamic = run(&cfg, photons, &rd);

    double worst = 0, total = 0;
    size_t n = 2 * (N + 1) * (N + 1), lit = 0;
    for (size_t v = 0; v < n; v++) {
        total += classic[v], lit += classic[v] > 0;
        double s = fmax(fabs(classic[v]), fabs(dynamic[v]));
        if (s > 0) worst = fmax(worst, fabs(classic[v] - dynamic[v]) / s);
    }
    printf("%llu photons: %zu of %zu vertex sides lit (mean %.4g W/m²); dynamic made %llu splits (%llu groups), "
           "classic %llu portions; largest relative difference %.2e\n",
           (unsigned long long)photons, lit, n, total / n, (unsigned long long)rd.splits, (unsigned long long)rd.groups,
           (unsigned long long)rc.portions, worst);
    free(classic), free(dynamic);
    /* The comparison means something only if both sides of most vertices were reached. */
    return worst <= 1e-12 && lit > n / 2 ? 0 : 1;
}
