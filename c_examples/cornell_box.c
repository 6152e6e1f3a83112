/*
 * The Cornell box through libimap's C API: builds the box with imap_add_mesh, runs to a
 * target error while printing the error-against-time table, and prints vertex values.
 *
 *   cornell_box [target_rel_error=0.02] [time_budget_s=60] [band_count=3] [classic|dynamic]
 *
 * band_count 3 runs in RGB; any other count runs that many spectral bands over 400–700 nm
 * (wall spectra approximated by smooth curves through the RGB reflectances).
 * It checks what the physics demands and exits non-zero otherwise: the energy balance
 * closes, and the floor shows colour bleeding (redder next to the red wall, greener next
 * to the green one).
 */
#include "cornell_scene.h"

static int print_progress(const ImapProgress *p, void *user) {
    (void)user;
    printf("%10.2f %14llu %14llu %12.3f %12.5f\n", p->elapsed_s, (unsigned long long)p->photons,
           (unsigned long long)p->hits, p->elapsed_s > 0 ? p->photons / p->elapsed_s / 1e6 : 0.0,
           p->rel_error);
    fflush(stdout);
    return 0;
}

/* Mean of one band over the floor vertices with x in [x0, x1]. */
static double floor_band(ImapContext *ctx, uint32_t floor_id, const Mesh *floor, int band, double x0, double x1) {
    double *e = malloc(floor->nv * sizeof(double));
    CHECK(imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, band, e, floor->nv));
    double sum = 0;
    int n = 0;
    for (size_t v = 0; v < floor->nv; v++) {
        double x = floor->xyz[3 * v], z = floor->xyz[3 * v + 2];
        if (x >= x0 && x <= x1 && z > 100 && z < 450) sum += e[v], n++;
    }
    free(e);
    return n ? sum / n : 0;
}

int main(int argc, char **argv) {
    double target = argc > 1 ? atof(argv[1]) : 0.02;
    double budget = argc > 2 ? atof(argv[2]) : 60.0;
    int bands = argc > 3 ? atoi(argv[3]) : 3;
    int classic = argc > 4 && strcmp(argv[4], "classic") == 0;
    ImapContext *ctx = NULL;

    /* One context: RGB or spectral, millimetre scene units, a fixed seed. */
    ImapConfig cfg;
    cornell_config(&cfg, bands);
    cfg.scheduler = classic ? IMAP_SCHEDULER_CLASSIC : IMAP_SCHEDULER_DYNAMIC;
    CHECK(imap_create(&cfg, &ctx));

    /* The closed box, every wall recording, 24 × 24 cells per wall. */
    const int n = 24;
    Cornell box;
    cornell_build(ctx, &box, bands, 1, 1, n);
    const Mesh floor = box.part[CB_FLOOR];
    const uint32_t floor_id = box.id[CB_FLOOR];

    /* Run to the target error, reporting error against time every half second. */
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.target_rel_error = target;
    run.time_budget_s = budget;
    run.progress_interval_s = 0.5;
    run.progress = print_progress;
    printf("Cornell box, %d band%s, target error %.3g, budget %.0f s\n", bands, bands == 1 ? "" : "s", target, budget);
    printf("%10s %14s %14s %12s %12s\n", "time [s]", "photons", "hits", "Mphotons/s", "rel. error");
    ImapReport rep;
    CHECK(imap_run(ctx, &run, &rep, sizeof rep));
    static const char *why[] = {"none", "photon count", "time budget", "target error", "cancelled"};
    printf("stopped by %s after %.2f s: %llu photons (%.3f M/s), %llu hits (%.3f M/s), error %.4f\n",
           why[rep.stop_reason], rep.run_wall_s, (unsigned long long)rep.photons, rep.run_photons / rep.run_wall_s / 1e6,
           (unsigned long long)rep.hits, rep.run_hits / rep.run_wall_s / 1e6, rep.rel_error);
    if (cfg.scheduler == IMAP_SCHEDULER_DYNAMIC)
        printf("dynamic scheduler, %u threads: %llu splits, %llu vertex groups, %llu of %llu portions applied by the "
               "calculating threads, processing threads busy %.0f %%, waited for portions %.2f s, peak queue %llu\n",
               rep.threads, (unsigned long long)rep.splits, (unsigned long long)rep.groups,
               (unsigned long long)rep.inline_portions, (unsigned long long)rep.portions, 100 * rep.accum_busy_fraction,
               rep.calc_wait_s, (unsigned long long)rep.peak_queue);
    else
        printf("classic scheduler, %u threads: accumulator busy %.0f %%, calculating threads waited %.2f s, peak queue %llu\n",
               rep.threads, 100 * rep.accum_busy_fraction, rep.calc_wait_s, (unsigned long long)rep.peak_queue);
    printf("energy: emitted %.4f W = absorbed %.4f + escaped %.4f + dropped %.4f\n", rep.emitted_w, rep.absorbed_w,
           rep.escaped_w, rep.dropped_w);

    /* Vertex values: irradiance on the floor next to the red wall (x > 435 mm) and next to
     * the green wall (x < 120 mm); the band nearest red and green. */
    int band_r = bands == 3 ? 0 : (int)lround((650.0 - 400) / 300 * (bands - 1));
    int band_g = bands == 3 ? 1 : (int)lround((550.0 - 400) / 300 * (bands - 1));
    if (bands == 1) band_r = band_g = 0;
    double lr = floor_band(ctx, floor_id, &floor, band_r, 435, 555), lg = floor_band(ctx, floor_id, &floor, band_g, 435, 555);
    double rr = floor_band(ctx, floor_id, &floor, band_r, 0, 120), rg = floor_band(ctx, floor_id, &floor, band_g, 0, 120);
    printf("floor next to the red wall:   R %.3f  G %.3f W/m² (R/G %.3f)\n", lr, lg, lr / lg);
    printf("floor next to the green wall: R %.3f  G %.3f W/m² (R/G %.3f)\n", rr, rg, rr / rg);
    size_t nv = floor.nv;
    double *e = malloc(nv * sizeof(double)), *err = malloc(nv * sizeof(double));
    CHECK(imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, band_g, e, nv));
    CHECK(imap_get_vertex_error(ctx, floor_id, IMAP_SIDE_FRONT, err, nv));
    size_t centre = (size_t)(n / 2) * (n + 1) + n / 2;
    printf("floor centre vertex (%.0f, %.0f, %.0f) mm: E = %.3f W/m² ± %.1f %%\n", floor.xyz[3 * centre],
           floor.xyz[3 * centre + 1], floor.xyz[3 * centre + 2], e[centre], 100 * err[centre]);

    int ok = 1;
    double balance = rep.absorbed_w + rep.escaped_w + rep.dropped_w;
    if (fabs(balance - rep.emitted_w) > 1e-9 * rep.emitted_w) {
        fprintf(stderr, "FAIL: energy balance does not close (%.12g vs %.12g)\n", balance, rep.emitted_w);
        ok = 0;
    }
    if (bands > 1 && !(lr / lg > 1.1 * (rr / rg))) {
        fprintf(stderr, "FAIL: no colour bleeding (R/G next to red %.3f, next to green %.3f)\n", lr / lg, rr / rg);
        ok = 0;
    }
    free(e), free(err);
    cornell_free(&box);
    imap_destroy(ctx);
    return ok ? 0 : 1;
}
