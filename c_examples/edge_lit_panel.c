/*
 * An edge-lit LED panel, the way an optics program would describe one to libimap: a
 * 300 × 200 × 4 mm PMMA light guide (n = 1.49) lit by six LEDs along its left edge, white
 * extraction dots printed on its bottom face (denser away from the LEDs), a white back
 * reflector under it, and an opal diffuser sheet over it (PMMA with a scattering bulk:
 * σs = 2000 /m, Henyey–Greenstein g = 0.6, σa = 2 /m). Light travels along the guide by
 * total internal reflection and leaves it only where a dot scatters it.
 *
 * A sensor plane 1 mm over the diffuser records the light leaving the panel (a 10 mm grid).
 * The example prints the panel's luminance over its face (L = M / π, the luminous exitance
 * of a Lambertian face), its uniformity Lmin / Lavg over the inner 80 % (where the standards
 * for panels measure it), and its efficiency: the flux out of the front over the LEDs'
 * flux, with where the rest goes. The run stops when every point of the output map is known
 * to `target_error`, or after `max_seconds`.
 *
 * usage: edge_lit_panel [target_error] [max_seconds]   (defaults: 0.01, 60)
 */
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

static void check(ImapContext *ctx, const char *what, ImapStatus s) {
    if (s != IMAP_OK) {
        fprintf(stderr, "%s: %s: %s\n", what, imap_status_name(s), imap_last_error(ctx));
        exit(1);
    }
}

/* The panel's size (m); the guide's bottom face in 2.5 mm cells (each printed or clear), the
 * sensor in 9.33 × 9 mm cells (NX × NY of them over the active area, and a guard ring of one
 * cell around it). */
#define W 0.30
#define D 0.20
#define T 0.004
enum { BX = 120, BY = 80, NX = 30, NY = 20 };

/* A closed box [lo, hi] with outward faces, its bottom face (z = lo) a BX × BY grid and the
 * other five faces two triangles each (its bottom's edges are split where the sides' are
 * not: closed as a surface, though not edge for edge, which a clear dielectric allows);
 * `bottom_material` gives each bottom cell's material, `other` the rest. Returns the
 * triangle count. */
static uint32_t slab(const double lo[3], const double hi[3], double *xyz, uint32_t *idx, uint32_t *mat,
                     const uint32_t *bottom_material, uint32_t other, uint32_t *vertex_count) {
    uint32_t nv = 0, nt = 0;
    for (int j = 0; j <= BY; j++)
        for (int i = 0; i <= BX; i++) {
            double *p = xyz + 3 * nv++;
            p[0] = lo[0] + (hi[0] - lo[0]) * i / BX, p[1] = lo[1] + (hi[1] - lo[1]) * j / BY, p[2] = lo[2];
        }
    for (int j = 0; j < BY; j++)
        for (int i = 0; i < BX; i++) {
            uint32_t a = (uint32_t)(j * (BX + 1) + i), b = a + 1, c = a + BX + 2, d = a + BX + 1;
            /* Normal −z: clockwise seen from above. */
            uint32_t *t = idx + 3 * nt;
            t[0] = a, t[1] = c, t[2] = b, t[3] = a, t[4] = d, t[5] = c;
            mat[nt] = mat[nt + 1] = bottom_material[j * BX + i];
            nt += 2;
        }
    /* The eight corners: bit 0 x, bit 1 y, bit 2 z. */
    uint32_t corner0 = nv;
    for (int k = 0; k < 8; k++) {
        double *p = xyz + 3 * nv++;
        p[0] = (k & 1) ? hi[0] : lo[0], p[1] = (k & 2) ? hi[1] : lo[1], p[2] = (k & 4) ? hi[2] : lo[2];
    }
    static const uint32_t faces[30] = {4, 5, 7, 4, 7, 6, /* top z = hi: normal +z */
                                       0, 1, 5, 0, 5, 4, /* y = lo: normal −y */
                                       2, 6, 7, 2, 7, 3, /* y = hi: normal +y */
                                       0, 4, 6, 0, 6, 2, /* x = lo: normal −x */
                                       1, 3, 7, 1, 7, 5}; /* x = hi: normal +x */
    for (int k = 0; k < 30; k++) idx[3 * nt + k] = corner0 + faces[k];
    for (int k = 0; k < 10; k++) mat[nt + k] = other;
    *vertex_count = nv;
    return nt + 10;
}

/* A closed box [lo, hi] with outward faces, as 12 triangles sharing its 8 corners (a
 * scattering medium needs a closed mesh: every edge shared by two triangles). */
static void closed_box(const double lo[3], const double hi[3], double xyz[24], uint32_t idx[36]) {
    for (int k = 0; k < 8; k++) {
        xyz[3 * k] = (k & 1) ? hi[0] : lo[0];
        xyz[3 * k + 1] = (k & 2) ? hi[1] : lo[1];
        xyz[3 * k + 2] = (k & 4) ? hi[2] : lo[2];
    }
    static const uint32_t faces[36] = {0, 2, 3, 0, 3, 1, /* z = lo: normal −z */
                                       4, 5, 7, 4, 7, 6, /* z = hi: normal +z */
                                       0, 1, 5, 0, 5, 4, /* y = lo: normal −y */
                                       2, 6, 7, 2, 7, 3, /* y = hi: normal +y */
                                       0, 4, 6, 0, 6, 2, /* x = lo: normal −x */
                                       1, 3, 7, 1, 7, 5}; /* x = hi: normal +x */
    memcpy(idx, faces, sizeof faces);
}

int main(int argc, char **argv) {
    double target = argc > 1 ? atof(argv[1]) : 0.01;
    double max_s = argc > 2 ? atof(argv[2]) : 60.0;

    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    ImapContext *ctx = NULL;
    check(NULL, "imap_create", imap_create(&cfg, &ctx));

    /* Materials: PMMA, the opal diffuser's PMMA with a scattering bulk, white print, white
     * back reflector, black LED bodies. */
    ImapMaterial m;
    uint32_t pmma, opal, print, reflector, black;
    imap_material_default(&m, sizeof m);
    m.ior_model = IMAP_IOR_CONSTANT, m.ior[0] = 1.49;
    check(ctx, "pmma", imap_add_material(ctx, &m, &pmma));
    double sigma_s = 2000, g = 0.6, sigma_a = 2;
    m.scattering_per_m = &sigma_s, m.scattering_count = 1;
    m.phase_g = &g, m.phase_g_count = 1;
    m.absorption_per_m = &sigma_a, m.absorption_count = 1;
    check(ctx, "opal", imap_add_material(ctx, &m, &opal));
    double rho;
    imap_material_default(&m, sizeof m);
    m.diffuse_reflectance = &rho, m.diffuse_reflectance_count = 1;
    rho = 0.90, check(ctx, "print", imap_add_material(ctx, &m, &print));
    rho = 0.95, check(ctx, "reflector", imap_add_material(ctx, &m, &reflector));
    rho = 0.0, check(ctx, "black", imap_add_material(ctx, &m, &black));

    /* The dots: in each 2.5 mm column, a share of the cells printed that grows from 12 % at the
     * LEDs to 90 % at the far edge (light that has travelled far is scarcer), spread along y by
     * the golden-ratio sequence (shifted per column) so every column holds its share. */
    static uint32_t dots[BX * BY];
    int printed = 0;
    for (int i = 0; i < BX; i++) {
        double x = (i + 0.5) / BX;
        double share = 0.12 + 0.78 * x * x;
        for (int j = 0; j < BY; j++) {
            double rank = fmod((j + 0.5) * 0.6180339887498949 + 0.37 * i, 1.0);
            dots[j * BX + i] = rank < share ? print : pmma;
            printed += rank < share;
        }
    }

    static double xyz[3 * ((BX + 1) * (BY + 1) + 8)];
    static uint32_t idx[3 * (2 * BX * BY + 10)], mat[2 * BX * BY + 10];
    uint32_t nv, nt;
    ImapMesh mesh;
    /* The light guide: not recorded (the sensor is the output map). */
    const double g_lo[3] = {0, 0, 0}, g_hi[3] = {W, D, T};
    nt = slab(g_lo, g_hi, xyz, idx, mat, dots, pmma, &nv);
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = xyz, mesh.vertex_count = nv, mesh.indices = idx, mesh.triangle_count = nt;
    mesh.triangle_materials = mat, mesh.material = pmma, mesh.flags = 0;
    uint32_t guide, diffuser, back, sensor;
    check(ctx, "light guide", imap_add_mesh(ctx, &mesh, &guide));
    /* The diffuser sheet, 2 mm thick, 2 mm over the guide. */
    const double d_lo[3] = {0, 0, T + 0.002}, d_hi[3] = {W, D, T + 0.004};
    double box[24];
    uint32_t box_idx[36];
    closed_box(d_lo, d_hi, box, box_idx);
    mesh.positions = box, mesh.vertex_count = 8, mesh.indices = box_idx, mesh.triangle_count = 12;
    mesh.triangle_materials = NULL, mesh.material = opal;
    check(ctx, "diffuser", imap_add_mesh(ctx, &mesh, &diffuser));
    /* The back reflector 1 mm under the guide, facing up. */
    double quad[12] = {-0.005, -0.005, -0.001, W + 0.005, -0.005, -0.001, W + 0.005, D + 0.005, -0.001,
                       -0.005, D + 0.005, -0.001};
    uint32_t quad_idx[6] = {0, 1, 2, 0, 2, 3};
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = quad, mesh.vertex_count = 4, mesh.indices = quad_idx, mesh.triangle_count = 2;
    mesh.material = reflector, mesh.flags = 0;
    check(ctx, "back reflector", imap_add_mesh(ctx, &mesh, &back));

    /* White tape on the other three edges, 0.3 mm from the guide. */
    for (int k = 0; k < 3; k++) {
        double x0 = k == 0 ? W + 0.0003 : 0, x1 = k == 0 ? W + 0.0003 : W;
        double y0 = k == 0 ? 0 : (k == 1 ? -0.0003 : D + 0.0003), y1 = k == 0 ? D : y0;
        double tape[12] = {x0, y0, 0, x1, y1, 0, x1, y1, T, x0, y0, T};
        uint32_t tape_idx[6] = {0, 1, 2, 0, 2, 3};
        imap_mesh_default(&mesh, sizeof mesh);
        mesh.positions = tape, mesh.vertex_count = 4, mesh.indices = tape_idx, mesh.triangle_count = 2;
        mesh.material = reflector, mesh.flags = IMAP_MESH_TWO_SIDED;
        uint32_t id;
        check(ctx, "edge tape", imap_add_mesh(ctx, &mesh, &id));
    }

    /* Six LEDs along the edge x = 0: 3 × 1.5 mm emitting faces 0.3 mm from the guide, facing
     * +x, Lambertian, 0.2 W each in every band (no recording). */
    for (int k = 0; k < 6; k++) {
        double y = D * (k + 0.5) / 6, z = T / 2;
        double led[12] = {-0.0003, y - 0.0015, z - 0.00075, -0.0003, y + 0.0015, z - 0.00075,
                          -0.0003, y + 0.0015, z + 0.00075, -0.0003, y - 0.0015, z + 0.00075};
        /* Normal (+y) × (+z) = +x. */
        uint32_t led_idx[6] = {0, 1, 2, 0, 2, 3};
        double exitance = 0.2 / (0.003 * 0.0015);
        imap_mesh_default(&mesh, sizeof mesh);
        mesh.positions = led, mesh.vertex_count = 4, mesh.indices = led_idx, mesh.triangle_count = 2;
        mesh.material = black, mesh.flags = 0;
        mesh.exitance = &exitance, mesh.exitance_count = 1;
        uint32_t id;
        check(ctx, "LED", imap_add_mesh(ctx, &mesh, &id));
    }

    /* The output map: a sensor 1 mm over the diffuser, facing down (it records the light
     * that crosses it upwards), over the panel's face: the active area's cells (material
     * `black`, the part the map is read on) and a guard ring of one cell around them
     * (material `ring`), so that the active area's edge points have whole cells on every
     * side, as its inner points do (an edge point's estimate would else average light over
     * half the area, a corner's over a quarter, with 1.4 and 2 times the error). */
    enum { GX = NX + 2, GY = NY + 2, GV = (GX + 1) * (GY + 1) };
    uint32_t ring;
    rho = 0.0, check(ctx, "ring", imap_add_material(ctx, &m, &ring));
    static double grid[3 * GV];
    static uint32_t grid_idx[6 * GX * GY], grid_mat[2 * GX * GY];
    const double cx = (W - 0.02) / NX, cy = (D - 0.02) / NY;
    for (int j = 0; j <= GY; j++)
        for (int i = 0; i <= GX; i++) {
            double *p = grid + 3 * (j * (GX + 1) + i);
            p[0] = 0.01 + cx * (i - 1), p[1] = 0.01 + cy * (j - 1), p[2] = T + 0.005;
        }
    for (int j = 0; j < GY; j++)
        for (int i = 0; i < GX; i++) {
            uint32_t a = (uint32_t)(j * (GX + 1) + i), *t = grid_idx + 6 * (j * GX + i);
            t[0] = a, t[1] = a + GX + 2, t[2] = a + 1, t[3] = a, t[4] = a + GX + 1, t[5] = a + GX + 2;
            int inner = i >= 1 && i <= NX && j >= 1 && j <= NY;
            grid_mat[2 * (j * GX + i)] = grid_mat[2 * (j * GX + i) + 1] = inner ? black : ring;
        }
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = grid, mesh.vertex_count = GV, mesh.indices = grid_idx;
    mesh.triangle_count = 2 * GX * GY, mesh.flags = IMAP_MESH_RECORD | IMAP_MESH_SENSOR;
    mesh.triangle_materials = grid_mat;
    check(ctx, "sensor", imap_add_mesh(ctx, &mesh, &sensor));

    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.time_budget_s = max_s;
    run.region_target = target, run.region_measure = IMAP_REGION_VERTICES;
    run.region_meshes = &sensor, run.region_mesh_count = 1;
    run.region_part_only = 1, run.region_part = black;
    /* Photons only: all of the panel's light reaches the sensor through the guide and the
     * diffuser, which is the photons' in every estimator, and light sampling's shadow rays
     * from the sensor would all end on the diffuser (it reached 8 % in 14.5 s against 5.5 s
     * for photons only). */
    run.estimator = IMAP_ESTIMATOR_PHOTONS;
    ImapReport rep;
    check(ctx, "imap_run", imap_run(ctx, &run, &rep, sizeof rep));

    /* The active area's points: the grid's vertices less its guard ring's outer ones. */
    enum { NV = (NX + 1) * (NY + 1) };
    static double grid_lux[GV], grid_err[GV], lux[NV], err[NV];
    check(ctx, "lux", imap_get_vertex_illuminance(ctx, sensor, IMAP_SIDE_FRONT, grid_lux, GV));
    check(ctx, "errors", imap_get_vertex_error(ctx, sensor, IMAP_SIDE_FRONT, grid_err, GV));
    for (int j = 0; j <= NY; j++)
        for (int i = 0; i <= NX; i++) {
            lux[j * (NX + 1) + i] = grid_lux[(j + 1) * (GX + 1) + i + 1];
            err[j * (NX + 1) + i] = grid_err[(j + 1) * (GX + 1) + i + 1];
        }
    ImapRegionStats st;
    check(ctx, "region", imap_get_region_stats(ctx, sensor, IMAP_SIDE_FRONT, black, &st, sizeof st));
    double absorbed_w[5];
    uint32_t parts[5] = {guide, diffuser, back, sensor, 0};
    for (int k = 0; k < 3; k++) check(ctx, "absorbed", imap_get_mesh_absorbed(ctx, parts[k], &absorbed_w[k]));
    /* What the diffuser's bulk absorbed, with its error: (W, σ) per band (the default
     * config's 3), then (lm, σ). */
    double bulk[2 * (3 + 1)];
    check(ctx, "diffuser's bulk", imap_get_medium_absorbed(ctx, diffuser, bulk, 8));

    printf("edge-lit panel %.0f × %.0f mm, %d of %d bottom cells (2.5 mm) printed, 6 LEDs of 0.2 W a band\n", W * 1000,
           D * 1000, printed, BX * BY);
    printf("\nluminance of the panel's active area, cd/m² (x from the LED edge, mm; 37 mm spacing):\n        ");
    for (int i = 0; i <= NX; i += 4) printf("%7.0f", 10 + 1000 * (W - 0.02) * i / NX);
    printf("\n");
    for (int j = NY; j >= 0; j -= 4) {
        printf("%6.0f  ", 10 + 1000 * (D - 0.02) * j / NY);
        for (int i = 0; i <= NX; i += 4) printf("%7.0f", lux[j * (NX + 1) + i] / PI);
        printf("\n");
    }
    /* Uniformity over the inner 80 % of the active area. */
    double lmin = 1e300, lsum = 0, worst = 0;
    int n = 0;
    for (int j = 0; j <= NY; j++)
        for (int i = 0; i <= NX; i++) {
            double x = (double)i / NX, y = (double)j / NY;
            if (err[j * (NX + 1) + i] > worst) worst = err[j * (NX + 1) + i];
            if (x < 0.1 || x > 0.9 || y < 0.1 || y > 0.9) continue;
            double l = lux[j * (NX + 1) + i] / PI;
            lmin = l < lmin ? l : lmin, lsum += l, n++;
        }
    double lavg = lsum / n;
    double eff = st.flux_lm / rep.emitted_lm;
    printf("\ninner 80 %%: Lavg %.0f cd/m², Lmin %.0f cd/m², uniformity Lmin/Lavg %.3f\n", lavg, lmin, lmin / lavg);
    printf("efficiency: %.1f lm of %.1f lm leave the active area's front (%.3f ± %.3f); absorbed in the guide and "
           "its dots %.1f %%, the diffuser %.1f %%, the back reflector %.1f %%; left elsewhere %.1f %%\n",
           st.flux_lm, rep.emitted_lm, eff, st.flux_lm_sigma / rep.emitted_lm, 100 * absorbed_w[0] / rep.emitted_w,
           100 * absorbed_w[1] / rep.emitted_w, 100 * absorbed_w[2] / rep.emitted_w,
           100 * (rep.escaped_lm - st.flux_lm) / rep.emitted_lm);
    printf("the diffuser's bulk absorbed %.2f ± %.2f lm (σa 2/m over 2 mm of scattering PMMA)\n", bulk[6], bulk[7]);
    printf("%llu photons in %.1f s (%s); worst point of the map %.2f %%\n", (unsigned long long)rep.photons,
           rep.elapsed_s, rep.stop_reason == IMAP_STOP_REGION_TARGET ? "map at its target" : "time budget",
           100 * worst);
    imap_destroy(ctx);
    /* Sanity for ctest: light leaves the front, no more than was emitted, everywhere over
     * the face, and the run reached its target. */
    int ok = eff > 0.2 && eff < 1.0 && lmin > 0 && lmin / lavg > 0.3 && worst <= target * 1.05 && bulk[6] > 0 &&
             bulk[7] < bulk[6] &&
             rep.stop_reason == IMAP_STOP_REGION_TARGET;
    return ok ? 0 : 1;
}
