/*
 * A seeded random-call harness over the whole C API, as a hostile integrator would call
 * it: valid calls mixed with NULL pointers, wrong counts, NaN/Inf/huge values, unknown
 * enums and ids, struct sizes that are wrong, calls out of order, contexts destroyed and
 * created again. (Pointers always point to as much memory as their counts say: anything
 * else is the caller's undefined behaviour, not the library's to catch.)
 *
 * Classes beyond single calls: progress callbacks that call back into the API on their own
 * context (every such call must be refused with IMAP_ERR_BUSY, imap_destroy included);
 * luminaire files whose counts promise more than a small memory budget (refused before
 * their values are read); paths to devices and folders given as state or image files.
 *
 * It checks, for every call: it returns (no crash, no abort: the process would die), in
 * bounded time; a failure has a specific status (never IMAP_ERR_INTERNAL or
 * IMAP_ERR_THREAD_LOST) and a one-line, non-empty message; and a failing call leaves the
 * map as it was (the first recorded mesh's values are compared before and after).
 *
 * usage: fuzz_api [calls] [seed]   (defaults: 100000 calls, seed 1)
 */
#include <imap.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static uint64_t rng_state;
static uint64_t next_u64(void) {
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static uint32_t below(uint32_t n) { return (uint32_t)(next_u64() % n); }
static double uniform(void) { return (double)(next_u64() >> 11) * (1.0 / 9007199254740992.0); }
static int chance(double p) { return uniform() < p; }

/* A double that is usually ordinary and sometimes hostile. */
static double hostile(double ordinary) {
    switch (below(24)) {
    case 0: return NAN;
    case 1: return INFINITY;
    case 2: return -INFINITY;
    case 3: return 1e300;
    case 4: return -1e300;
    case 5: return 1e-300;
    case 6: return 0.0;
    case 7: return -1.0;
    case 8: return 1e19;
    case 9: return 1e39;
    default: return ordinary;
    }
}

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#define MAX_CTX 3
#define MAX_MESHES 16

typedef struct {
    ImapContext *ctx;
    uint32_t bands;
    uint32_t materials;
    uint32_t meshes;
    size_t vertices[MAX_MESHES];
    int recorded[MAX_MESHES];
} Slot;

static Slot slots[MAX_CTX];
static long calls, failures_seen, problems;
static double slowest;
static const char *slowest_what = "";

static void problem(const char *what, ImapStatus s, const char *msg) {
    problems++;
    if (problems <= 20) printf("PROBLEM after %ld calls: %s -> %s \"%s\"\n", calls, what, imap_status_name(s), msg);
}

/* Checks one call's outcome. */
static void check(const char *what, ImapStatus s, const ImapContext *ctx, double t0, double bound_s) {
    double dt = now_s() - t0;
    calls++;
    if (dt > slowest) slowest = dt, slowest_what = what;
    if (dt > bound_s) {
        char buf[128];
        snprintf(buf, sizeof buf, "took %.2f s (bound %.1f s)", dt, bound_s);
        problem(what, s, buf);
    }
    if (s == IMAP_OK) return;
    failures_seen++;
    const char *msg = imap_last_error(ctx);
    if (s == IMAP_ERR_INTERNAL || s == IMAP_ERR_THREAD_LOST) problem(what, s, msg);
    if (msg == NULL || msg[0] == '\0' || strchr(msg, '\n') != NULL) problem(what, s, msg ? msg : "(null)");
    if (strncmp(imap_status_name(s), "IMAP_ERR_", 9) != 0) problem(what, s, "status without a name");
}

/* The first recorded mesh's values (all bands), to compare around failing calls. */
static int snapshot(Slot *sl, double *out, size_t cap, size_t *n) {
    for (uint32_t m = 0; m < sl->meshes; m++) {
        if (!sl->recorded[m]) continue;
        size_t nv = sl->vertices[m];
        if (nv * sl->bands > cap) return 0;
        for (uint32_t b = 0; b < sl->bands; b++)
            if (imap_get_vertex_energy(sl->ctx, m, IMAP_SIDE_FRONT, b, out + b * nv, nv) != IMAP_OK) return 0;
        *n = nv * sl->bands;
        return 1;
    }
    return 0;
}

static double before[1 << 16], after[1 << 16];

static void create(Slot *sl) {
    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 1 + below(3);
    cfg.scheduler = chance(0.5) ? IMAP_SCHEDULER_DYNAMIC : IMAP_SCHEDULER_CLASSIC;
    cfg.seed = next_u64();
    if (chance(0.3)) cfg.band_mode = IMAP_BANDS_SPECTRAL, cfg.band_count = 1 + below(12);
    if (chance(0.2)) cfg.max_groups = 1 + below(8);
    if (chance(0.1)) cfg.memory_budget_bytes = 1u << (16 + below(10));
    if (chance(0.3)) cfg.flags = chance(0.9) ? IMAP_CONFIG_NO_LIGHT_AIMING : below(8);
    /* Hostile configurations, now and then. */
    if (chance(0.15)) {
        switch (below(8)) {
        case 0: cfg.unit_m = hostile(1.0); break;
        case 1: cfg.band_count = below(2) ? 0 : 5000; break;
        case 2: cfg.threads = 2000; break;
        case 3: cfg.subd = below(100); break;
        case 4: cfg.struct_size = below(200); break;
        case 5: cfg.inline_apply = 3 + below(10); break;
        case 6: cfg.wavelength_min_nm = hostile(380); break;
        default: cfg.scheduler = 2 + below(5); break;
        }
    }
    double t0 = now_s();
    ImapContext *ctx = NULL;
    ImapStatus s = imap_create(chance(0.02) ? NULL : &cfg, &ctx);
    check("imap_create", s, NULL, t0, 5.0);
    memset(sl, 0, sizeof *sl);
    if (s == IMAP_OK) {
        sl->ctx = ctx;
        sl->bands = cfg.band_mode == IMAP_BANDS_SPECTRAL ? cfg.band_count : 3;
    } else if (ctx != NULL) {
        problem("imap_create wrote its out-parameter on failure", s, "");
    }
}

/* A grid of n × n cells at height z (normals +z), into xyz/idx. */
static void grid(int n, double z, double *xyz, uint32_t *idx) {
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            double *p = xyz + 3 * (j * (n + 1) + i);
            p[0] = (double)i / n, p[1] = (double)j / n, p[2] = z;
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = (uint32_t)(j * (n + 1) + i), *t = idx + 6 * (j * n + i);
            t[0] = a, t[1] = a + 1, t[2] = a + (uint32_t)n + 2, t[3] = a, t[4] = a + (uint32_t)n + 2,
            t[5] = a + (uint32_t)n + 1;
        }
}

/* A small valid IES file and a small valid EULUMDAT file, mutated by the harness. */
static const char IES_TEXT[] = "IESNA:LM-63-2002\n[TEST] fuzz\nTILT=NONE\n1 -1 1 4 1 1 2 -0.2 0 0\n1 1 10\n"
                               "0 30 60 90\n0\n1000 866 500 0\n";
static const char LDT_TEXT[] = "fuzz\n1\n1\n4\n90\n3\n45\nr\nl\nn\nf\nd\n0\n0\n0\n100\n0\n0\n0\n0\n0\n"
                               "100\n80\n1\n0\n1\n1\nLED\n1000\n3000K\n80\n10\n"
                               "0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n90\n180\n270\n0\n45\n90\n300\n200\n0\n";

/* `text` with a few hostile edits: bytes changed, the end cut off, numbers made NaN. */
static size_t mutate(const char *text, char *out, size_t cap) {
    size_t n = strlen(text);
    if (n > cap) n = cap;
    memcpy(out, text, n);
    int edits = (int)below(4);
    for (int e = 0; e < edits; e++) {
        switch (below(4)) {
        case 0: out[below((uint32_t)n)] = (char)below(256); break;
        case 1: n = below((uint32_t)n + 1); break;
        case 2: {
            size_t at = below((uint32_t)n + 1);
            if (n + 3 <= cap) memmove(out + at + 3, out + at, n - at), memcpy(out + at, "NaN", 3), n += 3;
            break;
        }
        default: out[below((uint32_t)n)] = "0123456789-.,\n "[below(15)]; break;
        }
        if (n == 0) break;
    }
    return n;
}

static void hostile_spectrum(ImapSpectrum *sp, double *table) {
    imap_spectrum_default(sp, sizeof *sp);
    sp->kind = below(9);
    sp->rgb[0] = hostile(1), sp->rgb[1] = hostile(0.5), sp->rgb[2] = hostile(0.2);
    sp->cct_k = hostile(3000);
    for (int i = 0; i < 8; i++) table[i] = chance(0.9) ? 380 + 50 * i : hostile(500), table[8 + i] = hostile(1);
    sp->table_nm = table, sp->table_values = table + 8, sp->table_count = below(9);
    sp->band_values = table + 8, sp->band_count = below(9);
    if (chance(0.05)) sp->struct_size = below(100);
}

static int progress_calls;
static int cancel_progress(const ImapProgress *p, void *user) {
    (void)p;
    (void)user;
    return ++progress_calls % 3 == 0;
}

/* A progress callback that calls back into the API on its own context: every such call
   must be refused with IMAP_ERR_BUSY (and change nothing, destroy included). */
static int reentrant_progress(const ImapProgress *p, void *user) {
    (void)p;
    ImapContext *ctx = (ImapContext *)user;
    ImapStatus s;
    double out[4];
    size_t n;
    switch (below(6)) {
    case 0: s = imap_destroy(ctx); break;
    case 1: s = imap_reset(ctx); break;
    case 2: s = imap_get_vertex_energy(ctx, 0, 0, 0, out, 4); break;
    case 3: s = imap_get_vertex_count(ctx, 0, &n); break;
    case 4: {
        ImapRunParams rp;
        imap_run_params_default(&rp, sizeof rp);
        rp.photons = 10;
        s = imap_run(ctx, &rp, NULL, 0);
        break;
    }
    default: s = imap_set_layers(ctx, 0); break;
    }
    if (s != IMAP_ERR_BUSY) problem("a call from a progress callback on its own context", s, imap_last_error(NULL));
    return chance(0.2);
}

int main(int argc, char **argv) {
    long n_calls = argc > 1 ? atol(argv[1]) : 100000;
    rng_state = argc > 2 ? strtoull(argv[2], NULL, 10) : 1;
    double start = now_s();
    for (int i = 0; i < MAX_CTX; i++) create(&slots[i]);
    static double xyz[3 * 33 * 33];
    static uint32_t idx[6 * 32 * 32], mats[2 * 32 * 32];
    double per_band[64];

    while (calls < n_calls) {
        Slot *sl = &slots[below(MAX_CTX)];
        if (sl->ctx == NULL) {
            create(sl);
            continue;
        }
        ImapContext *ctx = chance(0.01) ? NULL : sl->ctx;
        size_t n_before = 0;
        int have_map = snapshot(sl, before, sizeof before / sizeof before[0], &n_before);
        ImapStatus s = IMAP_OK;
        double t0 = now_s(), bound = 2.0;
        const char *what = "";
        uint32_t id = UINT32_MAX;
        switch (below(29)) {
        case 0: { /* a material */
            what = "imap_add_material";
            ImapMaterial m;
            imap_material_default(&m, sizeof m);
            size_t count = below(4) == 0 ? sl->bands : 1;
            if (chance(0.1)) count = below(70);
            for (int b = 0; b < 64; b++) per_band[b] = chance(0.9) ? 0.4 * uniform() : hostile(0.5);
            if (chance(0.6)) m.diffuse_reflectance = per_band, m.diffuse_reflectance_count = count;
            if (chance(0.2)) m.specular_reflectance = per_band + 1, m.specular_reflectance_count = 1;
            if (chance(0.1)) m.diffuse_transmittance = per_band + 2, m.diffuse_transmittance_count = 1;
            if (chance(0.15)) {
                m = (ImapMaterial){0};
                imap_material_default(&m, sizeof m);
                m.ior_model = 1 + below(3);
                for (int k = 0; k < 6; k++) m.ior[k] = chance(0.9) ? 1.5 + uniform() * 0.01 : hostile(1.5);
                if (m.ior_model == IMAP_IOR_SELLMEIER)
                    m.ior[0] = 1.04, m.ior[1] = 0.23, m.ior[2] = 1.01, m.ior[3] = 0.006, m.ior[4] = 0.02,
                    m.ior[5] = 103.6;
                if (chance(0.3)) m.absorption_per_m = per_band, m.absorption_count = 1;
            }
            if (chance(0.05)) m.ior_model = 4 + below(10);
            if (chance(0.05)) m.struct_size = below(64);
            if (chance(0.03)) m.diffuse_reflectance = NULL, m.diffuse_reflectance_count = 3;
            s = imap_add_material(ctx, chance(0.02) ? NULL : &m, chance(0.02) ? NULL : &id);
            if (s == IMAP_OK) sl->materials++;
            break;
        }
        case 1:
        case 2: { /* a mesh */
            what = "imap_add_mesh";
            int n = 1 + (int)below(12);
            size_t nv = (size_t)((n + 1) * (n + 1)), nt = (size_t)(2 * n * n);
            grid(n, uniform(), xyz, idx);
            ImapMesh d;
            imap_mesh_default(&d, sizeof d);
            d.positions = xyz, d.vertex_count = nv, d.indices = idx, d.triangle_count = nt;
            d.material = sl->materials ? below(sl->materials + (chance(0.05) ? 3 : 0)) : below(2);
            d.flags = below(4) | (chance(0.3) ? IMAP_MESH_SKIP_DEGENERATE : 0);
            if (chance(0.1)) d.flags |= 1u << (2 + below(20));
            if (chance(0.1)) xyz[3 * below((uint32_t)nv) + below(3)] = hostile(0.5);
            if (chance(0.1)) idx[below((uint32_t)(3 * nt))] = below((uint32_t)nv + 5);
            if (chance(0.05)) d.vertex_count = below(3), d.triangle_count = below(2);
            if (chance(0.1)) {
                for (size_t t = 0; t < nt; t++) mats[t] = sl->materials ? below(sl->materials) : 0;
                if (chance(0.2)) mats[below((uint32_t)nt)] = 1000;
                d.triangle_materials = mats;
            }
            if (chance(0.15)) {
                for (int b = 0; b < 64; b++) per_band[b] = chance(0.95) ? 5 + 10 * uniform() : hostile(5);
                d.exitance = per_band, d.exitance_count = chance(0.8) ? 1 : sl->bands;
            }
            if (chance(0.03)) d.struct_size = below(80);
            if (chance(0.02)) d.positions = NULL;
            s = imap_add_mesh(ctx, chance(0.02) ? NULL : &d, chance(0.02) ? NULL : &id);
            if (s == IMAP_OK && sl->meshes < MAX_MESHES) {
                sl->vertices[sl->meshes] = d.vertex_count;
                sl->recorded[sl->meshes] = (d.flags & IMAP_MESH_RECORD) != 0;
                sl->meshes++;
            } else if (s == IMAP_OK) {
                /* More meshes than tracked: start the context over. */
                imap_destroy(sl->ctx);
                sl->ctx = NULL;
            }
            break;
        }
        case 3: { /* a light */
            what = "imap_add_point_light/spot";
            double pos[3] = {hostile(0.5), hostile(0.5), hostile(2.0)}, dir[3] = {0, 0, hostile(-1)};
            if (chance(0.7)) pos[0] = 0.5, pos[1] = 0.5, pos[2] = 2;
            for (int b = 0; b < 64; b++) per_band[b] = chance(0.9) ? 1 + 100 * uniform() : hostile(10);
            size_t count = chance(0.8) ? 1 : (chance(0.5) ? sl->bands : below(70));
            if (chance(0.5))
                s = imap_add_point_light(ctx, chance(0.02) ? NULL : pos, per_band, count, &id);
            else
                s = imap_add_spot_light(ctx, pos, chance(0.02) ? NULL : dir, hostile(0.8), per_band, count, &id);
            break;
        }
        case 4:
        case 5: { /* a run */
            what = "imap_run";
            ImapRunParams p;
            imap_run_params_default(&p, sizeof p);
            p.photons = 1 + below(3000);
            if (chance(0.2)) p.time_budget_s = hostile(0.02), p.photons = chance(0.5) ? 0 : p.photons;
            if (chance(0.2)) p.progress_interval_s = hostile(0.005);
            if (chance(0.05)) p.target_rel_error = hostile(0.5);
            if (chance(0.05)) p.max_path_events = below(3);
            if (chance(0.1)) p.progress = cancel_progress;
            uint32_t rmeshes[3] = {below(sl->meshes + 2), below(sl->meshes + 2), below(sl->meshes + 2)};
            if (chance(0.1)) {
                p.region_target = hostile(0.3);
                p.region_measure = below(4);
                p.region_percentile = chance(0.7) ? 0 : hostile(80);
                p.region_meshes = chance(0.05) ? NULL : rmeshes;
                p.region_mesh_count = below(4);
            }
            if (chance(0.1)) { /* a range or a shard of the photons */
                p.photon_first = chance(0.5) ? below(5000) : next_u64();
                p.photon_count = chance(0.3) ? 0 : (chance(0.9) ? below(4000) : next_u64());
                p.shard_count = chance(0.05) ? 0 : 1 + below(4);
                p.shard_index = below(5);
                p.shard_block = chance(0.7) ? 0 : (chance(0.5) ? 64 * below(10) : below(1000));
            }
            if (chance(0.1)) { /* an estimator, sometimes bad or another than the map's */
                p.estimator = below(5);
                p.direct_samples = chance(0.6) ? 0 : (chance(0.9) ? below(33) : below(100000));
                p.direct_pass_photons = chance(0.6) ? 0 : (chance(0.5) ? below(64) : below(200000));
            }
            if (p.photons == 0 && !(p.time_budget_s > 0 && p.time_budget_s < 0.1)) p.photons = 500;
            if (chance(0.03)) p.struct_size = below(50);
            ImapReport r;
            s = imap_run(ctx, chance(0.02) ? NULL : &p, chance(0.5) ? &r : NULL, chance(0.05) ? below(40) : sizeof r);
            bound = 10.0;
            break;
        }
        case 6: { /* reading the map */
            what = "imap_get_vertex_energy/error";
            uint32_t m = below(sl->meshes + 2);
            size_t cap = below(2000);
            if (chance(0.5))
                s = imap_get_vertex_energy(ctx, m, below(3), below(sl->bands + 2), chance(0.03) ? NULL : after, cap);
            else
                s = imap_get_vertex_error(ctx, m, below(3), chance(0.03) ? NULL : after, cap);
            break;
        }
        case 7: { /* reports and history */
            what = "imap_get_report/history";
            ImapReport r;
            ImapProgress h[8];
            size_t count = 0;
            if (chance(0.5))
                s = imap_get_report(ctx, chance(0.03) ? NULL : &r, chance(0.1) ? below(300) : sizeof r);
            else
                s = imap_get_history(ctx, chance(0.03) ? NULL : h, below(9), chance(0.1) ? below(60) : sizeof h[0],
                                     chance(0.03) ? NULL : &count);
            break;
        }
        case 8: { /* counts and absorbed power */
            what = "imap_get_vertex_count/mesh_absorbed/medium_absorbed/dropped_triangles";
            size_t nv;
            double w;
            if (chance(0.4))
                s = imap_get_vertex_count(ctx, below(sl->meshes + 2), chance(0.03) ? NULL : &nv);
            else if (chance(0.5))
                s = imap_get_mesh_absorbed(ctx, below(sl->meshes + 2), chance(0.03) ? NULL : &w);
            else if (chance(0.6)) {
                double media[64];
                uint32_t mm = chance(0.1) ? IMAP_SCENE_MEDIUM : below(sl->meshes + 2);
                s = imap_get_medium_absorbed(ctx, mm, chance(0.03) ? NULL : media, below(65));
            } else
                s = imap_get_mesh_dropped_triangles(ctx, below(sl->meshes + 2), chance(0.03) ? NULL : &nv);
            break;
        }
        case 9: { /* a render, rarely */
            if (!chance(0.25)) continue;
            what = "imap_render";
            ImapCamera cam;
            ImapRenderParams rp;
            imap_camera_default(&cam, sizeof cam);
            imap_render_params_default(&rp, sizeof rp);
            cam.position[0] = 0.5, cam.position[1] = 0.5, cam.position[2] = 3;
            cam.width = 1 + below(12), cam.height = 1 + below(12);
            if (chance(0.1)) cam.position[below(3)] = hostile(1);
            if (chance(0.1)) cam.direction[below(3)] = hostile(-1);
            if (chance(0.1)) cam.up[below(3)] = hostile(1);
            if (chance(0.1)) cam.fov_y_deg = hostile(60);
            if (chance(0.05)) cam.width = below(2) ? 0 : 20000;
            rp.method = chance(0.95) ? below(4) : 4 + below(5);
            rp.passes = 1 + below(2);
            if (chance(0.1)) rp.initial_radius = hostile(0.1);
            if (chance(0.1)) rp.alpha = hostile(0.5);
            if (chance(0.1)) rp.time_budget_s = hostile(0.05), rp.passes = 0;
            if (chance(0.1)) rp.progress_interval_s = hostile(0.01);
            if (rp.passes == 0 && !(rp.time_budget_s > 0 && rp.time_budget_s < 0.1)) rp.passes = 1;
            static double img[12 * 12 * 64], err[12 * 12];
            size_t want = (size_t)cam.width * cam.height * sl->bands;
            size_t cap = want <= sizeof img / sizeof img[0] ? want : 0;
            if (chance(0.1) && cap) cap--;
            ImapRenderReport rr;
            s = imap_render(ctx, chance(0.02) ? NULL : &cam, &rp, img, cap, chance(0.5) ? err : NULL,
                            (size_t)cam.width * cam.height, &rr, sizeof rr);
            bound = 10.0;
            break;
        }
        case 10: { /* render report and history */
            what = "imap_get_render_report/history";
            ImapRenderReport rr;
            ImapProgress h[4];
            size_t count;
            if (chance(0.5))
                s = imap_get_render_report(ctx, &rr, chance(0.1) ? below(100) : sizeof rr);
            else
                s = imap_get_render_history(ctx, h, below(5), sizeof h[0], &count);
            break;
        }
        case 11: /* reset, sometimes */
            if (!chance(0.2)) continue;
            what = "imap_reset";
            s = imap_reset(ctx);
            have_map = 0; /* a reset clears the map by design */
            break;
        case 12: { /* status names, versions, messages: calls without a context */
            what = "imap_status_name/version/last_error";
            int32_t v = (int32_t)next_u64();
            const char *nm = imap_status_name(chance(0.5) ? v : (int32_t)below(30));
            if (nm == NULL || strncmp(nm, "IMAP_", 5) != 0) problem("imap_status_name", IMAP_OK, "no name");
            if (imap_version() == NULL || imap_last_error(NULL) == NULL || imap_last_error(sl->ctx) == NULL)
                problem("imap_version/last_error", IMAP_OK, "NULL");
            int64_t ev;
            s = imap_embree_version(ctx, chance(0.05) ? NULL : &ev);
            break;
        }
        case 13: { /* defaults with hostile sizes */
            what = "imap_*_default";
            static unsigned char buf[4096];
            size_t size = chance(0.5) ? below(4096) : below(200);
            switch (below(13)) {
            case 10: s = imap_sky_default((ImapSky *)(void *)buf, size); break;
            case 11: s = imap_sun_default((ImapSun *)(void *)buf, size); break;
            case 12: s = imap_sun_time_default((ImapSunTime *)(void *)buf, size); break;
            case 6: s = imap_light_default((ImapLight *)(void *)buf, size); break;
            case 7: s = imap_spectrum_default((ImapSpectrum *)(void *)buf, size); break;
            case 8: s = imap_luminaire_default((ImapLuminaire *)(void *)buf, size); break;
            case 9: s = imap_photometry_default((ImapPhotometry *)(void *)buf, size); break;
            case 0: s = imap_config_default(chance(0.05) ? NULL : (ImapConfig *)(void *)buf, size); break;
            case 1: s = imap_material_default((ImapMaterial *)(void *)buf, size); break;
            case 2: s = imap_mesh_default((ImapMesh *)(void *)buf, size); break;
            case 3: s = imap_run_params_default((ImapRunParams *)(void *)buf, size); break;
            case 4: s = imap_camera_default((ImapCamera *)(void *)buf, size); break;
            default: s = imap_render_params_default((ImapRenderParams *)(void *)buf, size); break;
            }
            ctx = NULL;
            have_map = 0;
            break;
        }
        case 15: { /* a light in photometric units, with a spectrum */
            what = "imap_add_light";
            ImapLight l;
            ImapSpectrum sp;
            double table[16];
            imap_light_default(&l, sizeof l);
            l.kind = below(5);
            l.unit = below(8);
            l.position[0] = 0.5, l.position[1] = 0.5, l.position[2] = 2;
            if (chance(0.2)) l.position[below(3)] = hostile(1);
            l.direction[2] = hostile(-1);
            l.half_angle_rad = hostile(0.5);
            l.aperture = below(3);
            l.aperture_size[0] = hostile(0.5), l.aperture_size[1] = hostile(0.5);
            l.aperture_up[0] = hostile(1);
            l.amount = hostile(1000);
            for (int b = 0; b < 64; b++) per_band[b] = chance(0.9) ? 1 + 100 * uniform() : hostile(10);
            l.band_power = per_band, l.band_power_count = chance(0.8) ? 1 : below(70);
            if (chance(0.03)) l.struct_size = below(200);
            hostile_spectrum(&sp, table);
            s = imap_add_light(ctx, chance(0.02) ? NULL : &l, chance(0.5) ? NULL : &sp, chance(0.02) ? NULL : &id);
            break;
        }
        case 16: { /* a luminaire from (mutated) file text or a table */
            what = "imap_add_luminaire_ies/ldt/table";
            static char text[4096];
            ImapLuminaire pl;
            ImapSpectrum sp;
            double table[16];
            imap_luminaire_default(&pl, sizeof pl);
            pl.position[0] = 0.5, pl.position[1] = 0.5, pl.position[2] = 2;
            if (chance(0.1)) pl.aim[below(3)] = hostile(0);
            if (chance(0.1)) pl.reference[below(3)] = hostile(0);
            if (chance(0.1)) pl.flux_scale = hostile(1);
            if (chance(0.1)) pl.lumens = hostile(500);
            pl.use_opening = chance(0.3) ? below(3) : 0;
            if (chance(0.03)) pl.struct_size = below(200);
            hostile_spectrum(&sp, table);
            const ImapSpectrum *spp = chance(0.7) ? NULL : &sp;
            switch (below(3)) {
            case 0: {
                size_t n = chance(0.3) ? strlen(IES_TEXT) : mutate(IES_TEXT, text, sizeof text);
                const char *t = n == strlen(IES_TEXT) && chance(0.3) ? IES_TEXT : text;
                s = imap_add_luminaire_ies(ctx, chance(0.02) ? NULL : t, n, NULL, 0, &pl, spp, &id);
                break;
            }
            case 1: {
                size_t n = chance(0.3) ? strlen(LDT_TEXT) : mutate(LDT_TEXT, text, sizeof text);
                const char *t = n == strlen(LDT_TEXT) && chance(0.3) ? LDT_TEXT : text;
                s = imap_add_luminaire_ldt(ctx, t, n, chance(0.02) ? NULL : &pl, spp, &id);
                break;
            }
            default: {
                ImapPhotometry ph;
                double v[4] = {0, 30, 60, 90}, h[4] = {0, 90, 180, 270}, cd[16];
                for (int i = 0; i < 16; i++) cd[i] = chance(0.95) ? 100 * uniform() : hostile(50);
                if (chance(0.1)) v[below(4)] = hostile(45);
                if (chance(0.1)) h[below(4)] = hostile(45);
                imap_photometry_default(&ph, sizeof ph);
                ph.photometric_type = chance(0.9) ? 1 : below(4);
                ph.vertical = v, ph.vertical_count = chance(0.9) ? 4 : below(5);
                ph.horizontal = h, ph.horizontal_count = chance(0.9) ? 4 : below(5);
                ph.candela = chance(0.02) ? NULL : cd;
                ph.multiplier = chance(0.9) ? 1 : hostile(2);
                ph.opening = below(4), ph.opening_width = hostile(0.3), ph.opening_length = hostile(0.3);
                ph.tilt_angles = v, ph.tilt_factors = h, ph.tilt_count = chance(0.9) ? 0 : below(5);
                s = imap_add_luminaire_table(ctx, &ph, &pl, spp, &id);
                break;
            }
            }
            break;
        }
        case 17: { /* photometric read-outs */
            what = "imap_get_vertex_illuminance/xyz/band_balance/efficacy/light_flux/region_stats/vertex_areas/"
                   "layers";
            uint32_t m = below(sl->meshes + 2);
            size_t cap = below(4000);
            double lm;
            uint32_t layer = chance(0.3) ? IMAP_LAYER_ALL - below(3) : below(4);
            switch (below(10)) {
            case 8:
                switch (below(3)) {
                case 0: s = imap_get_layer_energy(ctx, m, below(3), below(5), layer, chance(0.03) ? NULL : after, cap); break;
                case 1: s = imap_get_layer_illuminance(ctx, m, below(3), layer, chance(0.03) ? NULL : after, cap); break;
                default: s = imap_get_layer_error(ctx, m, below(3), layer, chance(0.03) ? NULL : after, cap); break;
                }
                break;
            case 9: {
                uint32_t g, d;
                switch (below(4)) {
                case 0: s = imap_set_layers(ctx, below(5)); break;
                case 1: s = imap_set_light_group(ctx, below(4), chance(0.9) ? below(4) : IMAP_MAX_LIGHT_GROUPS - below(2)); break;
                case 2:
                    /* Or the scene's medium: any material id, or none. */
                    if (chance(0.3)) {
                        s = imap_set_scene_medium(ctx, chance(0.3) ? IMAP_NO_MEDIUM : below(sl->materials + 2));
                        break;
                    }
                    s = imap_set_mesh_light_group(ctx, m, below(300));
                    break;
                default: s = imap_get_layers(ctx, chance(0.5) ? &g : NULL, chance(0.5) ? &d : NULL); break;
                }
                break;
            }
            case 5: {
                ImapRegionStats rs;
                s = imap_get_region_stats(ctx, m, below(3), chance(0.5) ? IMAP_ALL_PARTS : below(4),
                                          chance(0.03) ? NULL : &rs, chance(0.9) ? sizeof rs : below(200));
                break;
            }
            case 6:
                s = imap_get_region_band_flux(ctx, m, below(3), chance(0.5) ? IMAP_ALL_PARTS : below(4),
                                              chance(0.03) ? NULL : after, below(200));
                break;
            case 7: s = imap_get_vertex_areas(ctx, m, chance(0.03) ? NULL : after, cap); break;
            case 0: s = imap_get_vertex_illuminance(ctx, m, below(3), chance(0.03) ? NULL : after, cap); break;
            case 1: s = imap_get_vertex_xyz(ctx, m, below(3), chance(0.03) ? NULL : after, cap); break;
            case 2: s = imap_get_band_balance(ctx, below(6), chance(0.03) ? NULL : after, below(80)); break;
            case 3: s = imap_get_band_efficacy(ctx, chance(0.03) ? NULL : after, below(80)); break;
            default:
                s = imap_get_light_flux(ctx, below(6), chance(0.5) ? after : NULL, below(80), chance(0.5) ? &lm : NULL);
                break;
            }
            break;
        }
        case 18: { /* colour of tristimulus values: calls without a context */
            what = "imap_xyz_to_cct/chromaticity";
            double x[3] = {hostile(95), hostile(100), hostile(108)}, out[2], k, duv;
            s = chance(0.5) ? imap_xyz_to_cct(chance(0.03) ? NULL : x, chance(0.03) ? NULL : &k, chance(0.5) ? &duv : NULL)
                            : imap_xyz_chromaticity(x, chance(0.03) ? NULL : out);
            ctx = NULL;
            break;
        }
        case 19: { /* states: written, damaged, loaded or merged (also into other contexts) */
            what = "imap_state_*";
            size_t need = 0;
            s = imap_state_write(ctx, chance(0.9) ? (chance(0.2) ? IMAP_STATE_NO_MAP : 0) : below(8), "fz", below(3),
                                 NULL, 0, chance(0.03) ? NULL : &need);
            if (s != IMAP_ERR_BUFFER_TOO_SMALL) break;
            unsigned char *st = malloc(need + 16);
            size_t size = 0;
            s = imap_state_write(ctx, 0, "fz", 2, st, need + 16, &size);
            if (s == IMAP_OK) {
                if (chance(0.3)) st[below((uint32_t)size)] ^= (unsigned char)(1u << below(8));
                if (chance(0.2)) size = below((uint32_t)size + 1);
                ImapContext *into = chance(0.5) ? sl->ctx : slots[below(MAX_CTX)].ctx;
                if (into != sl->ctx) have_map = 0; /* another context's map may change */
                switch (below(4)) {
                case 0: s = imap_state_load(into, chance(0.03) ? NULL : st, size); break;
                case 1: s = imap_state_merge(into, st, size); break;
                case 2: /* no context: its message is the thread's */
                    s = imap_state_info(st, size, NULL, NULL, NULL);
                    into = NULL;
                    break;
                default: {
                    double *acc = NULL;
                    uint64_t n = 0;
                    s = chance(0.5) ? imap_map_accumulators(into, chance(0.03) ? NULL : &acc, &n)
                                    : imap_map_direct_accumulators(into, chance(0.03) ? NULL : &acc, &n);
                    break;
                }
                }
                ctx = into;
            }
            free(st);
            break;
        }
        case 20: { /* a sky, an image environment or the sun, with hostile fields */
            what = "imap_add_sky/sun";
            static float pixels[8 * 4 * 3];
            ImapSpectrum sp;
            double table[16];
            hostile_spectrum(&sp, table);
            if (chance(0.3)) {
                ImapSun sun;
                imap_sun_default(&sun, sizeof sun);
                sun.unit = below(8);
                sun.amount = chance(0.7) ? 1000 * uniform() + 1 : hostile(1000);
                sun.azimuth_deg = chance(0.7) ? 360 * uniform() : hostile(180);
                sun.zenith_deg = chance(0.7) ? 90 * uniform() : hostile(45);
                if (chance(0.1)) sun.north[below(3)] = hostile(1);
                if (chance(0.03)) sun.struct_size = below(200);
                s = imap_add_sun(ctx, chance(0.02) ? NULL : &sun, chance(0.5) ? NULL : &sp, chance(0.02) ? NULL : &id);
                break;
            }
            ImapSky sky;
            imap_sky_default(&sky, sizeof sky);
            sky.kind = below(5);
            sky.unit = below(6);
            sky.cie_type = below(17);
            sky.amount = chance(0.7) ? 1000 * uniform() + 1 : hostile(1000);
            sky.sun_azimuth_deg = chance(0.8) ? 360 * uniform() : hostile(180);
            sky.sun_zenith_deg = chance(0.8) ? 90 * uniform() : hostile(45);
            sky.rotation_deg = chance(0.8) ? 0 : hostile(10);
            if (chance(0.1)) sky.zenith[below(3)] = hostile(1);
            for (int k = 0; k < 8 * 4 * 3; k++) pixels[k] = chance(0.95) ? (float)uniform() : (float)hostile(1);
            sky.image_rgb = chance(0.05) ? NULL : pixels;
            /* Hostile sizes stay within the pixels passed (the contract the library
               cannot check), or come with no pixels at all. */
            sky.image_width = chance(0.9) ? 8 : below(9);
            sky.image_height = chance(0.9) ? 4 : below(5);
            if (chance(0.03)) sky.image_rgb = NULL, sky.image_width = (size_t)-1 / 2, sky.image_height = 7;
            if (chance(0.03)) sky.struct_size = below(200);
            if (chance(0.1))
                s = imap_add_sky_file(ctx, chance(0.5) ? "/nonexistent.hdr" : "CMakeLists.txt", &sky, &id);
            else
                s = imap_add_sky(ctx, chance(0.02) ? NULL : &sky, chance(0.5) ? NULL : &sp, chance(0.02) ? NULL : &id);
            break;
        }
        case 21: { /* a run whose progress callback calls back into the API */
            what = "imap_run (re-entrant callback)";
            ImapRunParams p;
            imap_run_params_default(&p, sizeof p);
            p.photons = 500 + below(3000);
            p.progress_interval_s = 0.001;
            p.progress = reentrant_progress;
            p.user_data = sl->ctx;
            s = imap_run(ctx, &p, NULL, 0);
            bound = 10.0;
            break;
        }
        case 22: { /* a luminaire whose counts promise more than a small budget holds */
            what = "imap_add_luminaire_ies/ldt (huge counts)";
            ImapConfig cfg;
            imap_config_default(&cfg, sizeof cfg);
            cfg.memory_budget_bytes = (uint64_t)(8 + below(64)) << 20;
            ImapContext *small = NULL;
            if (imap_create(&cfg, &small) != IMAP_OK) {
                problem("imap_create with a small budget", IMAP_OK, imap_last_error(NULL));
                continue;
            }
            static char text[1 << 16];
            uint32_t nv = 1000 + below(3000), nh = 1000 + below(3000);
            int n = 0;
            if (chance(0.5)) {
                n = snprintf(text, sizeof text, "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 %u %u 1 2 0 0 0\n1 1 10\n", nv, nh);
                for (uint32_t i = 0; i < nv && n < (int)sizeof text - 32; i++)
                    n += snprintf(text + n, sizeof text - (size_t)n, "%g ", 180.0 * i / (nv - 1));
                for (uint32_t i = 0; i < nh && n < (int)sizeof text - 32; i++)
                    n += snprintf(text + n, sizeof text - (size_t)n, "%g ", 360.0 * i / (nh - 1));
                ImapLuminaire pl;
                imap_luminaire_default(&pl, sizeof pl);
                s = imap_add_luminaire_ies(small, text, (size_t)n, NULL, 0, &pl, NULL, &id);
            } else {
                n = snprintf(text, sizeof text,
                             "f\n1\n0\n%u\n0.1\n%u\n0.05\nr\nl\nn\nf\nd\n100\n100\n50\n0\n0\n0\n0\n0\n0\n100\n100\n1\n0\n"
                             "1\n1\nLED\n1000\n3000K\n80\n10\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n",
                             nh, nv);
                ImapLuminaire pl;
                imap_luminaire_default(&pl, sizeof pl);
                s = imap_add_luminaire_ldt(small, text, (size_t)n, &pl, NULL, &id);
            }
            if (s == IMAP_OK) problem(what, s, "a table of millions of values announced and none given was accepted");
            check(what, s, small, t0, 5.0);
            imap_destroy(small);
            continue;
        }
        case 23: { /* paths to devices and folders as state and image files */
            what = "imap_state_load_file/merge_file/add_sky_file (device)";
            const char *paths[] = {"/dev/zero", "/dev/urandom", "/", "/dev/null"};
            const char *path = paths[below(4)];
            ImapSky sky;
            imap_sky_default(&sky, sizeof sky);
            switch (below(3)) {
            case 0: s = imap_state_load_file(ctx, path); break;
            case 1: s = imap_state_merge_file(ctx, path); break;
            default: s = imap_add_sky_file(ctx, path, &sky, &id); break;
            }
            if (s == IMAP_OK) problem(what, s, "a device read as a file");
            break;
        }
        case 14: /* destroy and create, sometimes */
            if (!chance(0.05)) continue;
            imap_destroy(sl->ctx);
            imap_destroy(NULL);
            sl->ctx = NULL;
            calls++;
            continue;
        default: { /* the common case: a small valid run on a scene that has one */
            what = "imap_run (valid)";
            ImapRunParams p;
            imap_run_params_default(&p, sizeof p);
            p.photons = 200 + below(800);
            s = imap_run(ctx, &p, NULL, 0);
            bound = 10.0;
            break;
        }
        }
        check(what, s, ctx, t0, bound);
        if (s != IMAP_OK && have_map && sl->ctx != NULL) {
            size_t n_after = 0;
            if (!snapshot(sl, after, sizeof after / sizeof after[0], &n_after) || n_after != n_before ||
                memcmp(before, after, n_before * sizeof(double)) != 0)
                problem(what, s, "a failing call changed the map");
        }
        if (s != IMAP_OK && id != UINT32_MAX) problem(what, s, "out_id written on failure");
    }
    for (int i = 0; i < MAX_CTX; i++) imap_destroy(slots[i].ctx);
    printf("%ld calls (%ld failing, each with its own status and message) in %.1f s; slowest %.2f s (%s); %ld "
           "problem(s)\n",
           calls, failures_seen, now_s() - start, slowest, slowest_what, problems);
    return problems == 0 ? 0 : 1;
}
