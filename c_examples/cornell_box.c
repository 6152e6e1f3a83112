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
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHECK(call)                                                                  \
    do {                                                                             \
        ImapStatus s_ = (call);                                                      \
        if (s_ != IMAP_OK) {                                                         \
            fprintf(stderr, "%s failed: %s: %s\n", #call, imap_status_name(s_),      \
                    imap_last_error(ctx));                                           \
            exit(1);                                                                 \
        }                                                                            \
    } while (0)

/* A growing triangle mesh. */
typedef struct {
    double *xyz;
    uint32_t *idx;
    size_t nv, nt, cap_v, cap_t;
} Mesh;

static void push_vertex(Mesh *m, const double p[3]) {
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 256;
        m->xyz = realloc(m->xyz, 3 * m->cap_v * sizeof(double));
    }
    memcpy(m->xyz + 3 * m->nv++, p, 3 * sizeof(double));
}

static void push_triangle(Mesh *m, uint32_t a, uint32_t b, uint32_t c) {
    if (m->nt == m->cap_t) {
        m->cap_t = m->cap_t ? 2 * m->cap_t : 256;
        m->idx = realloc(m->idx, 3 * m->cap_t * sizeof(uint32_t));
    }
    uint32_t *t = m->idx + 3 * m->nt++;
    t[0] = a, t[1] = b, t[2] = c;
}

/* A quad o + s·u + t·v, s,t in [0,1], as an n×n grid; its normal is u × v. */
static void add_quad(Mesh *m, const double o[3], const double u[3], const double v[3], int n) {
    uint32_t base = (uint32_t)m->nv;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            double s = (double)i / n, t = (double)j / n, p[3];
            for (int k = 0; k < 3; k++) p[k] = o[k] + s * u[k] + t * v[k];
            push_vertex(m, p);
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            push_triangle(m, a, b, c);
            push_triangle(m, a, c, d);
        }
}

/* An upright block on the floor: centre (cx, cz), half sizes (hx, hz), height h, rotated
 * by `angle` about the vertical axis; normals point out. */
static void add_block(Mesh *m, double cx, double cz, double hx, double hz, double h, double angle, int n) {
    double c = cos(angle), s = sin(angle);
    double ex[3] = {2 * hx * c, 0, -2 * hx * s}, ez[3] = {2 * hz * s, 0, 2 * hz * c}, ey[3] = {0, h, 0};
    double corner[3] = {cx - hx * c - hz * s, 0, cz + hx * s - hz * c};
    double top[3] = {corner[0], h, corner[2]};
    double neg_ex[3] = {-ex[0], 0, -ex[2]}, neg_ez[3] = {-ez[0], 0, -ez[2]};
    double far_x[3] = {corner[0] + ex[0], 0, corner[2] + ex[2]};
    double far_xz[3] = {far_x[0] + ez[0], 0, far_x[2] + ez[2]};
    double far_z[3] = {corner[0] + ez[0], 0, corner[2] + ez[2]};
    add_quad(m, top, ez, ex, n);         /* top, normal +y */
    add_quad(m, corner, ey, ex, n);      /* front, normal −z (before rotation) */
    add_quad(m, far_x, ey, ez, n);       /* right, +x */
    add_quad(m, far_xz, ey, neg_ex, n);  /* back, +z */
    add_quad(m, far_z, ey, neg_ez, n);   /* left, −x */
}

/* Per-band values of an RGB triple: RGB mode takes it as is; spectral bands interpolate
 * smoothly between B (450 nm), G (550 nm) and R (650 nm). */
static void spectrum(const double rgb[3], int bands, double *out) {
    if (bands == 3) {
        memcpy(out, rgb, 3 * sizeof(double));
        return;
    }
    for (int b = 0; b < bands; b++) {
        double nm = bands == 1 ? 550 : 400 + 300.0 * b / (bands - 1);
        double v;
        if (nm <= 450) v = rgb[2];
        else if (nm <= 550) v = rgb[2] + (rgb[1] - rgb[2]) * (nm - 450) / 100;
        else if (nm <= 650) v = rgb[1] + (rgb[0] - rgb[1]) * (nm - 550) / 100;
        else v = rgb[0];
        out[b] = v;
    }
}

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
    imap_config_default(&cfg);
    if (bands != 3) {
        cfg.band_mode = IMAP_BANDS_SPECTRAL;
        cfg.band_count = (uint32_t)bands;
        cfg.wavelength_min_nm = 400;
        cfg.wavelength_max_nm = 700;
    }
    cfg.unit_m = 0.001;
    cfg.seed = 2026;
    cfg.scheduler = classic ? IMAP_SCHEDULER_CLASSIC : IMAP_SCHEDULER_DYNAMIC;
    CHECK(imap_create(&cfg, &ctx));

    /* Materials: the classic box's white, red and green walls, and a black lamp. */
    const double white[3] = {0.73, 0.73, 0.73}, red[3] = {0.63, 0.065, 0.05}, green[3] = {0.14, 0.45, 0.091};
    double *buf = malloc(bands * sizeof(double));
    uint32_t m_white, m_red, m_green, m_lamp;
    ImapMaterial mat;
    memset(&mat, 0, sizeof mat);
    mat.diffuse_reflectance = buf;
    mat.diffuse_reflectance_count = (size_t)bands;
    spectrum(white, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_white));
    spectrum(red, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_red));
    spectrum(green, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_green));
    memset(&mat, 0, sizeof mat);
    CHECK(imap_add_material(ctx, &mat, &m_lamp));

    /* Geometry in mm: the room [0,555]³ open at z = 555 (the camera side is closed here
     * too, white, so no light is lost), normals pointing in. */
    const int n = 24;
    const double L = 555;
    Mesh floor = {0}, ceiling = {0}, back = {0}, left = {0}, right = {0}, front = {0}, blocks = {0}, lamp = {0};
    add_quad(&floor, (double[3]){0, 0, 0}, (double[3]){0, 0, L}, (double[3]){L, 0, 0}, n);
    add_quad(&ceiling, (double[3]){0, L, 0}, (double[3]){L, 0, 0}, (double[3]){0, 0, L}, n);
    add_quad(&back, (double[3]){0, 0, L}, (double[3]){0, L, 0}, (double[3]){L, 0, 0}, n);
    add_quad(&front, (double[3]){0, 0, 0}, (double[3]){L, 0, 0}, (double[3]){0, L, 0}, n);
    add_quad(&left, (double[3]){0, 0, 0}, (double[3]){0, L, 0}, (double[3]){0, 0, L}, n);
    add_quad(&right, (double[3]){L, 0, 0}, (double[3]){0, 0, L}, (double[3]){0, L, 0}, n);
    add_block(&blocks, 185, 169, 82.5, 82.5, 165, -0.29, 6);
    add_block(&blocks, 368, 351, 82.5, 82.5, 330, 0.29, 8);
    /* The lamp: a 130 × 105 mm patch just under the ceiling, facing down. */
    add_quad(&lamp, (double[3]){213, L - 0.5, 227}, (double[3]){130, 0, 0}, (double[3]){0, 0, 105}, 1);

    struct { Mesh *m; uint32_t mat; const char *name; uint32_t id; } parts[] = {
        {&floor, 0, "floor", 0}, {&ceiling, 0, "ceiling", 0}, {&back, 0, "back", 0},
        {&front, 0, "front", 0}, {&left, 0, "left (red)", 0}, {&right, 0, "right (green)", 0},
        {&blocks, 0, "blocks", 0},
    };
    parts[4].mat = m_red, parts[5].mat = m_green;
    for (size_t i = 0; i < sizeof parts / sizeof parts[0]; i++) {
        if (i != 4 && i != 5) parts[i].mat = m_white;
        ImapMesh d;
        memset(&d, 0, sizeof d);
        d.positions = parts[i].m->xyz, d.vertex_count = parts[i].m->nv;
        d.indices = parts[i].m->idx, d.triangle_count = parts[i].m->nt;
        d.material = parts[i].mat;
        d.flags = IMAP_MESH_RECORD;
        CHECK(imap_add_mesh(ctx, &d, &parts[i].id));
    }
    /* The lamp emits 17 W per band (exitance over its 0.01365 m²); it does not record. */
    double exitance = 17.0 / (0.130 * 0.105);
    uint32_t lamp_id;
    ImapMesh d;
    memset(&d, 0, sizeof d);
    d.positions = lamp.xyz, d.vertex_count = lamp.nv, d.indices = lamp.idx, d.triangle_count = lamp.nt;
    d.material = m_lamp, d.exitance = &exitance, d.exitance_count = 1;
    CHECK(imap_add_mesh(ctx, &d, &lamp_id));

    /* Run to the target error, reporting error against time every half second. */
    ImapRunParams run;
    imap_run_params_default(&run);
    run.target_rel_error = target;
    run.time_budget_s = budget;
    run.progress_interval_s = 0.5;
    run.progress = print_progress;
    printf("Cornell box, %d band%s, target error %.3g, budget %.0f s\n", bands, bands == 1 ? "" : "s", target, budget);
    printf("%10s %14s %14s %12s %12s\n", "time [s]", "photons", "hits", "Mphotons/s", "rel. error");
    ImapReport rep;
    CHECK(imap_run(ctx, &run, &rep));
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

    /* Vertex values: irradiance on the floor, left half (next to the red wall) and right
     * half (next to the green wall); the band nearest red and green. */
    int band_r = bands == 3 ? 0 : (int)lround((650.0 - 400) / 300 * (bands - 1));
    int band_g = bands == 3 ? 1 : (int)lround((550.0 - 400) / 300 * (bands - 1));
    if (bands == 1) band_r = band_g = 0;
    double lr = floor_band(ctx, parts[0].id, &floor, band_r, 0, 120), lg = floor_band(ctx, parts[0].id, &floor, band_g, 0, 120);
    double rr = floor_band(ctx, parts[0].id, &floor, band_r, 435, 555), rg = floor_band(ctx, parts[0].id, &floor, band_g, 435, 555);
    printf("floor next to the red wall:   R %.3f  G %.3f W/m² (R/G %.3f)\n", lr, lg, lr / lg);
    printf("floor next to the green wall: R %.3f  G %.3f W/m² (R/G %.3f)\n", rr, rg, rr / rg);
    size_t nv = floor.nv;
    double *e = malloc(nv * sizeof(double)), *err = malloc(nv * sizeof(double));
    CHECK(imap_get_vertex_energy(ctx, parts[0].id, IMAP_SIDE_FRONT, band_g, e, nv));
    CHECK(imap_get_vertex_error(ctx, parts[0].id, IMAP_SIDE_FRONT, err, nv));
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
    free(e), free(err), free(buf);
    Mesh *all[] = {&floor, &ceiling, &back, &front, &left, &right, &blocks, &lamp};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) free(all[i]->xyz), free(all[i]->idx);
    imap_destroy(ctx);
    return ok ? 0 : 1;
}
