/*
 * The host's own BSDF through the C API: a Lambertian reflector computed by callbacks
 * (called from two threads) absorbs what the library's own Lambertian surface absorbs;
 * callbacks that fail during a run give IMAP_ERR_HOST_BSDF naming the material, and the
 * context stays usable; bad descriptions get their statuses; a material struct of the
 * 0.2.2 size (before the surface models) is still accepted.
 */
#include <imap.h>

#include <math.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

static const double PI = 3.14159265358979323846;
static int failures = 0;
static atomic_long calls;
static long fail_after = -1;

static void check(int ok, const char *what, const ImapContext *ctx) {
    if (!ok) {
        fprintf(stderr, "FAIL: %s (%s)\n", what, ctx ? imap_last_error(ctx) : "");
        failures++;
    }
}

/* Lambert, rho = 0.5 in every band: f = rho / pi above the surface. */
static int eval(void *user, const double *wo, const double *wi, int front, double *f, uint32_t bands) {
    (void)user, (void)wo, (void)front;
    long n = atomic_fetch_add(&calls, 1);
    if (fail_after >= 0 && n >= fail_after) return -7;
    for (uint32_t b = 0; b < bands; b++) f[b] = wi[2] > 0 ? 0.5 / PI : 0.0;
    return 0;
}

static int sample(void *user, const double *wo, const double *u, int front, double *wi, double *pdf) {
    (void)user, (void)wo, (void)front;
    double r = sqrt(u[1]), phi = 2 * PI * u[2], z = sqrt(1 - u[1]);
    if (z <= 0) return 1;
    wi[0] = r * cos(phi), wi[1] = r * sin(phi), wi[2] = z;
    *pdf = z / PI;
    return 0;
}

static int pdf(void *user, const double *wo, const double *wi, int front, double *p) {
    (void)user, (void)wo, (void)front;
    *p = wi[2] > 0 ? wi[2] / PI : 0.0;
    return 0;
}

static double floor_xyz[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
static uint32_t floor_idx[6] = {0, 1, 2, 0, 2, 3};
/* A black wall at x = 0.6 facing the light: it absorbs the part of the floor's reflection
 * that leaves toward it, which depends on the reflection's directions. */
static double wall_xyz[12] = {0.6, -1, 0, 0.6, -1, 1, 0.6, 1, 1, 0.6, 1, 0};

/* A run of `photons` over a floor of the host's BSDF (or the ideal Lambertian one): the
 * absorbed share of the emitted power, or -1 when the run failed (its status in *status). */
static double absorbed(int host, uint64_t photons, ImapStatus *status, char *message, size_t len) {
    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2, cfg.seed = 5;
    ImapContext *ctx = NULL;
    if (imap_create(&cfg, &ctx) != IMAP_OK) return -2;
    ImapHostBsdf h;
    imap_host_bsdf_default(&h, sizeof h);
    h.eval = eval, h.sample = sample, h.pdf = pdf, h.peak = 0.5 / PI;
    double rho = 0.5, pos[3] = {0.2, 0.1, 0.8}, watts = 1;
    ImapMaterial m;
    imap_material_default(&m, sizeof m);
    if (host)
        m.surface = IMAP_SURFACE_HOST, m.host_bsdf = &h;
    else
        m.diffuse_reflectance = &rho, m.diffuse_reflectance_count = 1;
    uint32_t mat, mesh, light, black_id;
    ImapMaterial black;
    imap_material_default(&black, sizeof black);
    ImapMesh d;
    imap_mesh_default(&d, sizeof d);
    d.positions = floor_xyz, d.vertex_count = 4, d.indices = floor_idx, d.triangle_count = 2;
    d.flags = IMAP_MESH_RECORD;
    ImapStatus s = imap_add_material(ctx, &m, &mat);
    if (s == IMAP_OK) d.material = mat, s = imap_add_mesh(ctx, &d, &mesh);
    if (s == IMAP_OK) s = imap_add_material(ctx, &black, &black_id);
    if (s == IMAP_OK) {
        d.positions = wall_xyz, d.material = black_id;
        s = imap_add_mesh(ctx, &d, &mesh);
    }
    if (s == IMAP_OK) s = imap_add_point_light(ctx, pos, &watts, 1, &light);
    check(s == IMAP_OK, "scene", ctx);
    ImapRunParams p;
    imap_run_params_default(&p, sizeof p);
    p.photons = photons, p.progress_interval_s = 0.05;
    ImapReport rep;
    *status = imap_run(ctx, &p, &rep, sizeof rep);
    snprintf(message, len, "%s", imap_last_error(ctx));
    double share = *status == IMAP_OK ? rep.absorbed_w / rep.emitted_w : -1;
    if (*status != IMAP_OK) {
        /* Usable after the failure: a reset and a run of the light alone on another mesh. */
        fail_after = -1;
        check(imap_reset(ctx) == IMAP_OK, "reset after a host failure", ctx);
        check(imap_run(ctx, &p, &rep, sizeof rep) == IMAP_OK, "run after a host failure", ctx);
    }
    imap_destroy(ctx);
    return share;
}

int main(void) {
    char message[1024];
    ImapStatus s;
    uint64_t n = 400000;
    double ideal = absorbed(0, n, &s, message, sizeof message);
    double host = absorbed(1, n, &s, message, sizeof message);
    double sigma = sqrt(ideal * (1 - ideal) / (double)n) * sqrt(2.0);
    printf("absorbed share: ideal %.5f, host BSDF %.5f (%.2f sigma), %ld callback calls\n", ideal, host,
           (host - ideal) / sigma, (long)atomic_load(&calls));
    check(ideal > 0.1 && fabs(host - ideal) < 4 * sigma, "host Lambert absorbs what Lambert absorbs", NULL);

    /* A failing callback: the check at adding makes some 25 000 calls, so fail after 60 000. */
    atomic_store(&calls, 0);
    fail_after = 60000;
    double none = absorbed(1, 5000000, &s, message, sizeof message);
    check(none < 0 && s == IMAP_ERR_HOST_BSDF, "a failing host BSDF gives IMAP_ERR_HOST_BSDF", NULL);
    check(strstr(message, "material 0") && strstr(message, "eval returned -7"), message, NULL);

    /* Bad descriptions, and the 0.2.2 struct size. */
    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    ImapContext *ctx = NULL;
    check(imap_create(&cfg, &ctx) == IMAP_OK, "create", NULL);
    ImapHostBsdf h;
    imap_host_bsdf_default(&h, sizeof h);
    h.eval = eval, h.pdf = pdf;
    ImapMaterial m;
    imap_material_default(&m, sizeof m);
    m.surface = IMAP_SURFACE_HOST;
    uint32_t id;
    check(imap_add_material(ctx, &m, &id) == IMAP_ERR_NULL_POINTER, "host_bsdf NULL", ctx);
    m.host_bsdf = &h;
    check(imap_add_material(ctx, &m, &id) == IMAP_ERR_NULL_POINTER, "sample callback NULL", ctx);
    h.sample = sample, h.flags = 8;
    check(imap_add_material(ctx, &m, &id) == IMAP_ERR_INVALID_ARGUMENT, "unknown host flag", ctx);
    h.flags = 0, h.peak = -1;
    check(imap_add_material(ctx, &m, &id) == IMAP_ERR_INVALID_ARGUMENT, "negative peak", ctx);
    h.peak = 0;
    check(imap_add_material(ctx, &m, &id) == IMAP_OK, "host BSDF (valid)", ctx);
    double recip = -1, alb = -1;
    check(imap_get_table_check(ctx, id, &recip, &alb) == IMAP_OK, "host BSDF check", ctx);
    check(recip < 1e-12 && fabs(alb - 0.5) < 0.03, "host BSDF check values", NULL);
    double rho = 0.5;
    ImapMaterial old;
    imap_material_default(&old, sizeof old);
    old.diffuse_reflectance = &rho, old.diffuse_reflectance_count = 1;
    old.struct_size = (uint32_t)offsetof(ImapMaterial, surface);
    check(imap_add_material(ctx, &old, &id) == IMAP_OK, "ImapMaterial of the 0.2.2 size", ctx);
    imap_destroy(ctx);
    if (failures) {
        fprintf(stderr, "%d failure(s)\n", failures);
        return 1;
    }
    puts("host_bsdf: ok");
    return 0;
}
